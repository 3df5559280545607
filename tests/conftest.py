import os
import sys

# Tests import the scene scripts as modules (scikit-fem style: every example is a regression test).
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
