"""The ``ngsgel`` command: ``ngsgel list``, ``ngsgel run SCENE [options]``, ``ngsgel reproduce``.

``ngsgel run SCENE --help`` shows a scene's own options with units and defaults; everything after
the scene's name is handed to the scene's ``main``. ``ngsgel --threads N COMMAND ...`` runs the
command with NGSolve on ``N`` threads and the BLAS libraries on one (``ngsgel.set_threads``);
without it NGSolve takes its default (every core). The gears scenes keep their own ``--threads``.
"""

from __future__ import annotations

import argparse
import sys

from .scenes import SCENES, scene
from .threads import using_threads

USAGE = """ngsgel [--threads N] COMMAND ...              N NGSolve threads (BLAS on one) for the command
ngsgel list                                   the scenes, with their thesis chapter
ngsgel run SCENE [--quick] [--out DIR] [...]  run one scene (ngsgel run SCENE --help)
ngsgel reproduce [--quick] [--only ch3,ch4] --out DIR
                                              the thesis's numbers against ours, one report"""


def list_scenes(stream=None) -> None:
    stream = stream or sys.stdout
    width = max(map(len, SCENES))
    for name, entry in SCENES.items():
        stream.write(f"{name:<{width}}  {entry.chapter:<6}  {entry.summary()}\n")


def run_scene(name: str, argv: list[str]):
    entry = scene(name)
    module = entry.load()
    # argparse names the program after argv[0]: make a scene's --help read "ngsgel run NAME"
    saved, sys.argv = sys.argv, [f"ngsgel run {entry.name}", *argv]
    try:
        return module.main(argv)
    finally:
        sys.argv = saved


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="ngsgel", usage=USAGE, description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=("list", "run", "reproduce"))
    if argv and argv[0] == "--threads":
        if len(argv) < 2 or not argv[1].isdigit() or int(argv[1]) < 1:
            parser.error(f"--threads needs an integer >= 1, got {argv[1] if len(argv) > 1 else 'nothing'}")
        with using_threads(int(argv[1])):
            return main(argv[2:])
    if not argv or argv[0] in ("-h", "--help"):
        parser.print_help()
        return 0
    command, rest = argv[0], argv[1:]
    if command == "list":
        parser.parse_args([command])
        list_scenes()
    elif command == "run":
        if not rest or rest[0] in ("-h", "--help"):
            print(USAGE)
            list_scenes()
            return 0
        try:
            entry = scene(rest[0])
        except ValueError as error:
            parser.error(str(error))
        run_scene(entry.name, rest[1:])
    elif command == "reproduce":
        from .reproduce import main as reproduce

        reproduce(rest)
    else:
        parser.parse_args([command])
    return 0


if __name__ == "__main__":
    sys.exit(main())
