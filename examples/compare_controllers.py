"""Compare designs I and II with LQR on paths I and II: metrics table and figures.

Run: ``python examples/compare_controllers.py [--t-end 3] [--out out/compare]``
"""

import argparse

from delta_pin.studies.experiments import RunSpec
from delta_pin.studies.reproduce import compare, markdown_table


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=3.0)
    parser.add_argument("--out", default="out/compare")
    args = parser.parse_args()
    specs = [
        RunSpec(controller=c, path=p, plant="analytic", t_end=args.t_end)
        for p in ("I", "II")
        for c in ("design1", "design2", "lqr")
    ]
    print(markdown_table(compare(specs, args.out, workers=1)))


if __name__ == "__main__":
    main()
