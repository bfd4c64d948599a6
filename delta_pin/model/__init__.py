"""The robot: its URDF description, the paper's analytic model (kinematics, dynamics, friction),
the constrained Pinocchio model, :class:`~delta_pin.model.robot.Delta`, trajectories and
validation. Imports nothing above it (docs/architecture.md section 2)."""
