"""Check the paper's analytic model against the constrained Pinocchio model (eqs. 7-10).

Run: ``python examples/validate_model.py [--samples 200]``
"""

import argparse

import delta_pin as dp
from delta_pin.model.validation import validate


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=200)
    args = parser.parse_args()
    report = validate(dp.load_delta(), samples=args.samples)
    print(report.table())
    # The same check fails for uniform-rod forearms: the paper's lumped model has model error there.
    rod = validate(dp.load_delta(forearm_inertia="rod"), samples=args.samples)
    print(f"\nwith forearm_inertia='rod': {'passes' if rod.passed else 'fails, as expected'}")


if __name__ == "__main__":
    main()
