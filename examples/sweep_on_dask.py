"""A sweep over the uncertainty magnitudes on a Dask cluster (a local one by default).

Run: ``python examples/sweep_on_dask.py [--scheduler tcp://host:8786] [--points 3]``
(needs the [dask] extra; results are identical whichever executor runs them).
"""

import argparse

import numpy as np

from delta_pin.studies.experiments import RunSpec
from delta_pin.studies.sweep import grid_specs, run_sweep


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scheduler", default="local", help="Dask scheduler address, or 'local'")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--points", type=int, default=3, help="grid points per axis")
    parser.add_argument("--t-end", type=float, default=1.0)
    parser.add_argument("--out", default="out/sweep_dask")
    args = parser.parse_args()
    grid = list(np.linspace(0.0, 0.9, args.points))
    base = RunSpec(controller="design1", plant="analytic", t_end=args.t_end, gains={"rho0": 0.02})
    result = run_sweep(
        grid_specs(base, {"delta_m": grid, "delta_f": grid}),
        args.out,
        scheduler=args.scheduler,
        workers=args.workers,
    )
    print(result.summary())
    for point in result:
        print(
            f"delta_m={point.spec.delta_m:.2f} delta_f={point.spec.delta_f:.2f} "
            f"rho_hat_max={point.metrics['rho_hat_max']:.3f}"
        )


if __name__ == "__main__":
    main()
