"""Which equilibrium the graded plate's first step after its second snap reaches
(docs/benchmarks.md, "Which of the two end states is the branch's").

From a finished default run (``ngsgel run graded-plate-shell --out DIR``) the state before the
second snap (``DIR/checkpoint_leg2.npz``) is relaxed again at ``mu`` + 1e-3 as the scene does,
then followed to ``mu = -0.00164`` in one natural step and in steps of 1e-4, and on in 1e-4
steps to ``--to``. Printed: each path's points (``mu``, Newton iterations, negative count, rim
purity), the largest difference of the two states at -0.00164 and, with ``--to 0``, of the
small steps' end and the run's end state (``DIR/state_end.npz``).

    python scripts/plate_branch_check.py DIR [--to -0.0006 | --to 0]
"""

from __future__ import annotations

import argparse

import numpy as np

from ngsgel.continuation import Checkpoint, ContinuationError, StabilityOptions, follow_path
from ngsgel.relaxation import settle
from ngsgel.scenes.graded_plate_shell import STALL_WINDOW, RimWaves
from ngsgel.scenes.shell_cases import GRADED_N0, GRADED_NR, graded_plate_shell
from ngsgel.threads import using_threads


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run", help="folder of a finished default graded-plate-shell run")
    parser.add_argument("--to", type=float, default=-0.0006, help="mu where the small steps end")
    parser.add_argument("--threads", type=int, default=2)
    args = parser.parse_args()
    with using_threads(args.threads):
        shell, mesh, _ = graded_plate_shell(10.0, maxh=0.2, order=3, t=0.01, half=True, n0=GRADED_N0, nR=GRADED_NR)
        rim = RimWaves(shell, mesh, half=True)
        before = Checkpoint.load(f"{args.run}/checkpoint_leg2.npz")
        shell.restore_state(before.state)
        shell.mu.Set(before.parameter + 1e-3)  # the scene's snap_overshoot
        relaxed = settle(shell, parameter=shell.mu)
        start, mu_start = shell.save_state(), shell.mu.Get()
        print(f"relaxed at mu {mu_start:.6g}: {relaxed.steps} pseudo-time steps, purity {rim.values()['rim_purity']:.4f}")

        def follow(step: float, target: float, label: str, *, state=start, mu=mu_start):
            shell.restore_state(state)
            shell.mu.Set(mu)
            try:
                path = follow_path(shell, shell.mu, method="natural", step=step, max_step=step, min_step=step / 1000,
                                   target=target, stability=StabilityOptions(tol=1e-4), keep_states=True,
                                   qoi={"purity": lambda: rim.values()["rim_purity"]},
                                   newton_options={"stall_window": STALL_WINDOW})
            except ContinuationError as error:  # a stall is a result here: its points are printed
                path = error.result
            print(f"{label} ({path.stop_reason}):",
                  [(round(p.parameter, 6), p.iterations, p.negative, round(p.qoi["purity"], 4)) for p in path.points])
            return path

        one = follow(0.00164, -0.00164, "one step")
        small = follow(1e-4, -0.00164, "steps of 1e-4")
        difference = np.max(np.abs(one.points[-1].state - small.points[-1].state))
        print(f"at -0.00164: largest difference {difference:.3g}, largest |state| "
              f"{np.max(np.abs(small.points[-1].state)):.3g}")
        on = follow(1e-4, args.to, "steps of 1e-4 on", state=small.points[-1].state, mu=small.points[-1].parameter)
        if args.to == 0.0 and on.points[-1].parameter == 0.0:
            end = np.load(f"{args.run}/state_end.npz")
            print(f"at mu = 0 against the run's end state: largest difference "
                  f"{np.max(np.abs(on.points[-1].state - end['state'])):.3g}")


if __name__ == "__main__":
    main()
