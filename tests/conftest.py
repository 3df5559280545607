import os
import sys

# The benchmarks in scripts/ are not installed; their tests import them by path. Scenes are
# imported from the package (ngsgel.scenes).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
