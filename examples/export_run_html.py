"""Simulate a short run and export it as ONE standalone HTML page (headless: no server, no window).

Run: ``python examples/export_run_html.py --out out/run.html --t-end 4``, then open the page in
any browser, offline: the robot replays the run at real-time speed, with the desired path (green)
and the platform's actual path (red).
"""

from __future__ import annotations

import argparse

import numpy as np

import delta_pin as dp
from delta_pin.sim.runner import simulate
from delta_pin.viz.meshcat_export import export_html


def main() -> None:
    parser = argparse.ArgumentParser(
        description="Simulate a short run and export it to a standalone HTML page."
    )
    parser.add_argument("--out", default="out/run.html", help="HTML file to write (default: out/run.html)")
    parser.add_argument("--t-end", type=float, default=2.0, help="run duration [s] (default: 2)")
    parser.add_argument(
        "--ghost", action="store_true", help="also draw the desired pose as a translucent robot"
    )
    args = parser.parse_args()

    robot = dp.load_delta()  # the paper's Table 1 robot
    run = simulate(
        robot, dp.PDGravity(dp.DeltaNominalModel(robot)), dp.PathII(), plant="analytic", t_end=args.t_end
    )
    error = np.linalg.norm(run.xyz - run.xyz_d, axis=1).max()
    path = export_html(run, args.out, show_desired_ghost=args.ghost)
    print(f"{args.t_end:g} s along path II, max tracking error {error * 1e3:.2f} mm")
    print(f"wrote {path} ({path.stat().st_size / 1e6:.2f} MB)")


if __name__ == "__main__":
    main()
