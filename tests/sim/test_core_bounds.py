# ruff: noqa: E501  (the cases are Python source in strings, one case a line)
"""The compiled core never reads or writes outside an array (issue 36, item 2): every binding of
``delta_pin.compiled._core`` checks the sizes, indices and ranges it is given before it touches
memory, and answers a bad call with one ``ValueError`` naming the argument.

Each group of cases runs in a subprocess of its own (a bad call used to kill the process: SIGSEGV,
SIGBUS, or heap corruption found at exit), one line per case. Every test asserts that the
process was not killed by a signal, that each case raised the error it names -- ``ValueError``
from the core's checks, ``TypeError`` from nanobind's own type check where an index is negative
and the binding takes it unsigned, or where a preallocated output table is not C-contiguous --
and that the message names the argument. The valid objects the cases start from are the shipped
five-bar (``dp.load_robot("five_bar")``: nq = nv = 4, one 3-row closure, two actuators) and the
paper's Delta on its reduced plant (``dp.load_delta()``).

Cases marked ``"ok"`` are calls that must go through with the right answer: a non-contiguous
view (``a[::2]``) handed to an argument the binding copies (every vector and matrix but the
sampled loop's output tables) is read as its values, not as the memory under it.

``scripts/asan_core.sh`` runs this file against a core built with AddressSanitizer, where an
access outside an array fails even when it happens not to crash.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import pytest

PRELUDE = """
import json
import numpy as np
import delta_pin as dp
from delta_pin.compiled.core import core
from delta_pin.model.core_model import core_chain, model_spec
from delta_pin.sim.compiled_plant import build_core_analytic_plant, build_core_plant

m = core()
robot = dp.load_robot("five_bar")
SPEC = model_spec(robot.model)
NQ, NV, NF, NJ = robot.model.nq, robot.model.nv, robot.model.nframes, robot.model.njoints
FRAMES = [(int(a), int(b), int(s)) for a, b, s in robot._frames]
AQ = np.asarray(robot.actuated_q_indices, np.int32)
AV = np.asarray(robot.actuated_indices, np.int32)
DV = np.asarray(robot.dependent_indices, np.int32)
EE = int(robot.end_effector)
DOF = len(AQ)
q0 = np.array(robot.reference_configuration, float)
alpha0 = q0[AQ].copy()
NAN = float("nan")
chain = core_chain(robot)


def describe(closures=FRAMES, couplings=(), aq=AQ, av=AV, dv=DV, idle=0, ee=EE, spec=SPEC, springs=None):
    return m.ChainDescription(
        spec, list(closures), list(couplings), np.asarray(aq, np.int32), np.asarray(av, np.int32),
        np.asarray(dv, np.int32), idle, ee, m.JointSprings() if springs is None else springs,
    )


def springs(q=(), v=(), k=(), ref=(), d=(), damper_v=(), damper_d=()):
    out = m.JointSprings()
    out.q_index, out.v_index = np.asarray(q, np.int32), np.asarray(v, np.int32)
    out.k, out.ref, out.d = np.asarray(k, float), np.asarray(ref, float), np.asarray(d, float)
    out.damper_v, out.damper_d = np.asarray(damper_v, np.int32), np.asarray(damper_d, float)
    return out


def use(description):  # a model of the description, then a call that reads its closures
    model = m.ClosedChainModel(description)
    model.configuration(alpha0 + 0.05, q0)
    model.closure_gap(q0)


def tables(n, cols, rows=None):
    rows = n + 1 if rows is None else rows
    return np.zeros((rows, cols)), np.zeros((n + 1, cols)), np.zeros((n + 1, 3)), np.zeros(n + 1)


def case(name, arg, call):
    try:
        call()
    except Exception as exc:
        outcome, message = type(exc).__name__, str(exc)
    else:
        outcome, message = "ok", ""
    print(json.dumps({"case": name, "arg": arg, "outcome": outcome, "message": message[:2000]}), flush=True)
"""

# (group, code): each group's cases, run after PRELUDE in one subprocess; a case is
# case(name, "argument[:expected outcome]", call) with the outcome ValueError unless named
GROUPS = {
    "chain_description": """
case("closure of 0 rows", "closures", lambda: use(describe(closures=[(FRAMES[0][0], FRAMES[0][1], 0)])))
case("closure of -3 rows", "closures", lambda: use(describe(closures=[(FRAMES[0][0], FRAMES[0][1], -3)])))
case("closure of 4 rows", "closures", lambda: use(describe(closures=[(FRAMES[0][0], FRAMES[0][1], 4)])))
case("closure frame = nframes", "closures", lambda: use(describe(closures=[(NF, FRAMES[0][1], 3)])))
case("closure frame 10**9", "closures", lambda: use(describe(closures=[(FRAMES[0][0], 10**9, 3)])))
case("closure frame -1", "closures:TypeError", lambda: use(describe(closures=[(-1, FRAMES[0][1], 3)])))
case("end effector = nframes", "end_effector", lambda: use(describe(ee=NF)))
case("end effector -1", "end_effector:TypeError", lambda: use(describe(ee=-1)))
case("actuated_q entry = nq", "actuated_q", lambda: use(describe(aq=[AQ[0], NQ])))
case("actuated_q entry -1", "actuated_q", lambda: use(describe(aq=[AQ[0], -1])))
case("actuated_q shorter than actuated_v", "actuated_q", lambda: use(describe(aq=[AQ[0]])))
case("actuated_v entry = nv", "actuated_v", lambda: use(describe(av=[AV[0], NV])))
case("dependent_v entry -1", "dependent_v", lambda: use(describe(dv=[DV[0], -1])))
case("dependent_v entry = nv", "dependent_v", lambda: use(describe(dv=[DV[0], NV])))
case("idle_dof -1", "idle_dof", lambda: use(describe(idle=-1)))
case("idle_dof > dependent joints", "idle_dof", lambda: use(describe(idle=3)))
case("coupling q1 = nq", "couplings", lambda: use(describe(couplings=[(NQ, 0, -1, -1, 0.0, 0.0, np.zeros(1))])))
case("coupling v2 = nv", "couplings", lambda: use(describe(couplings=[(0, 0, 1, NV, 0.0, 0.0, np.zeros(2))])))
case("coupling q2 -1 with v2 = 1", "couplings", lambda: use(describe(couplings=[(0, 0, -1, 1, 0.0, 0.0, np.zeros(2))])))
case("no dependent joint under a closure", "dependent_v:ok", lambda: use(describe(dv=[])))
""",
    "model_spec": """
def spec_with(**fields):  # the five-bar's ModelSpec with some fields replaced
    spec = model_spec(robot.model)
    for name, value in fields.items():
        setattr(spec, name, value)
    return spec
def joint(kind, axis=(0.0, 0.0, 1.0)):
    made = m.JointSpec()
    made.type, made.axis = kind, np.asarray(axis, float)
    return made
def build(spec):
    use(describe(spec=spec))
J, P = list(SPEC.joints), SPEC.placements
case("the model as handed over", "model:ok", lambda: build(SPEC))
case("a joint type the core does not rebuild", "JointModelMimic", lambda: build(spec_with(joints=[joint("JointModelMimic")] + J[1:])))
case("a joint of no type", "no type", lambda: build(spec_with(joints=[joint("")] + J[1:])))
case("an unaligned axis of norm 2", "axis", lambda: build(spec_with(joints=[joint("JointModelRevoluteUnaligned", (0, 0, 2.0))] + J[1:])))
case("an unaligned axis of NaN", "axis", lambda: build(spec_with(joints=[joint("JointModelRevoluteUnaligned", (NAN, 0, 1.0))] + J[1:])))
case("a composite of no parts", "parts", lambda: build(spec_with(joints=[joint("JointModelComposite")] + J[1:])))
case("a joint its own parent", "parent", lambda: build(spec_with(parents=np.arange(1, NJ, dtype=np.int32))))
case("a parent -1", "parent", lambda: build(spec_with(parents=np.full(NJ - 1, -1, np.int32))))
case("one joint name too few", "joint names", lambda: build(spec_with(joint_names=list(SPEC.joint_names)[:-1])))
case("one placement too few", "placements", lambda: build(spec_with(placements=P[:-1])))
case("a NaN placement", "placements", lambda: build(spec_with(placements=np.full_like(P, NAN))))
case("one inertia too few", "inertias", lambda: build(spec_with(inertias=SPEC.inertias[:-1])))
case("an infinite inertia", "inertias", lambda: build(spec_with(inertias=np.full_like(SPEC.inertias, np.inf))))
case("a frame's parent joint = njoints", "parent joint", lambda: build(spec_with(frame_joints=np.full(NF - 1, NJ, np.int32))))
case("a frame's parent after it", "parent frame", lambda: build(spec_with(frame_parents=np.arange(2, NF + 1, dtype=np.int32))))
case("a frame of type 3", "FrameType", lambda: build(spec_with(frame_types=np.full(NF - 1, 3, np.int32))))
case("one frame name too many", "frame names", lambda: build(spec_with(frame_names=list(SPEC.frame_names) + ["extra"])))
case("armature of nv + 1", "armature", lambda: build(spec_with(armature=np.zeros(NV + 1))))
case("NaN gravity", "gravity", lambda: build(spec_with(gravity=np.full(6, NAN))))
""",
    "closed_chain_model": """
model = m.ClosedChainModel(chain)
ad = np.zeros(DOF)
case("closure_gap of an empty q", "q", lambda: model.closure_gap(np.zeros(0)))
case("configuration: alpha of 3", "alpha", lambda: model.configuration(np.zeros(3), q0))
case("configuration: empty guess", "guess", lambda: model.configuration(alpha0, np.zeros(0)))
case("velocity_map of an empty q", "q", lambda: model.velocity_map(np.zeros(0)))
case("velocity_map of q of nq + 1", "q", lambda: model.velocity_map(np.zeros(NQ + 1)))
case("velocity_map at NaN", "q", lambda: model.velocity_map(np.full(NQ, NAN)))
case("project_state: empty v", "v", lambda: model.project_state(q0, np.zeros(0)))
case("project_state: NaN v", "v", lambda: model.project_state(q0, np.full(NV, NAN)))
case("reduced_terms: empty q", "q", lambda: model.reduced_terms(np.zeros(0), ad))
case("reduced_terms: alpha_dot of 3", "alpha_dot", lambda: model.reduced_terms(q0, np.zeros(3)))
case("reduced_terms: NaN alpha_dot", "alpha_dot", lambda: model.reduced_terms(q0, np.full(DOF, NAN)))
case("end_effector_position: empty q", "q", lambda: model.end_effector_position(np.zeros(0)))
case("end_effector_position: NaN q", "q", lambda: model.end_effector_position(np.full(NQ, NAN)))
case("end_effector_positions: alpha of 1 column", "alpha", lambda: model.end_effector_positions(np.zeros((4, 1)), q0))
case("end_effector_positions: empty guess", "guess", lambda: model.end_effector_positions(np.zeros((4, DOF)), np.zeros(0)))
case("frame_jacobian: frame = nframes", "frame", lambda: model.frame_jacobian(q0, NF))
case("frame_jacobian: frame 10**6", "frame", lambda: model.frame_jacobian(q0, 10**6))
case("frame_jacobian: frame -1", "frame:TypeError", lambda: model.frame_jacobian(q0, -1))
case("frame_jacobian: empty q", "q", lambda: model.frame_jacobian(np.zeros(0), EE))
case("frame_acceleration_drift: frame = nframes", "frame", lambda: model.frame_acceleration_drift(q0, ad, NF))
case("frame_acceleration_drift: NaN alpha_dot", "alpha_dot", lambda: model.frame_acceleration_drift(q0, np.full(DOF, NAN), EE))
xyz = np.tile(model.end_effector_position(q0), (3, 1))
times, zeros3 = np.array([0.0, 0.01, 0.02]), np.zeros((3, 3))
rows = np.array([0, 1], np.int32)
def path(frame=EE, rows=rows, times=times, xyz=xyz, xyz_dot=zeros3, xyz_ddot=zeros3, alpha=alpha0, q=q0):
    return model.joint_reference(frame, rows, times, xyz, xyz_dot, xyz_ddot, alpha, q)
case("joint_reference: valid", "frame:ok", lambda: path())
case("joint_reference: frame = nframes", "frame", lambda: path(frame=NF))
case("joint_reference: row 3", "rows", lambda: path(rows=np.array([0, 3], np.int32)))
case("joint_reference: row -1", "rows", lambda: path(rows=np.array([0, -1], np.int32)))
case("joint_reference: one row for two actuators", "rows", lambda: path(rows=np.array([0], np.int32)))
case("joint_reference: xyz_dot of 2 columns", "xyz_dot", lambda: path(xyz_dot=np.zeros((3, 2))))
case("joint_reference: xyz_ddot of 2 rows", "xyz_ddot", lambda: path(xyz_ddot=np.zeros((2, 3))))
case("joint_reference: alpha0 of 3", "alpha0", lambda: path(alpha=np.zeros(3)))
case("joint_reference: empty q_start", "q_start", lambda: path(q=np.zeros(0)))
case("joint_reference: NaN xyz_dot", "xyz_dot", lambda: path(xyz_dot=np.full((3, 3), NAN)))
case("joint_reference: NaN time", "times", lambda: path(times=np.array([0.0, NAN, 0.02])))
case("joint_reference: non-contiguous xyz", "xyz:ok", lambda: path(xyz=np.repeat(xyz, 2, axis=0)[::2]))
states = np.tile(alpha0, (3, 1))
def torques(alpha=states, alpha_dot=np.zeros((3, DOF)), alpha_ddot=np.zeros((3, DOF)), guess=q0):
    return model.actuated_torques(alpha, alpha_dot, alpha_ddot, guess)
case("actuated_torques: valid", "alpha:ok", lambda: torques())
case("actuated_torques: alpha_dot of 1 column", "alpha_dot", lambda: torques(alpha_dot=np.zeros((3, 1))))
case("actuated_torques: alpha_ddot of 2 rows", "alpha_ddot", lambda: torques(alpha_ddot=np.zeros((2, DOF))))
case("actuated_torques: NaN alpha_ddot", "alpha_ddot", lambda: torques(alpha_ddot=np.full((3, DOF), NAN)))
case("actuated_torques: empty guess", "guess", lambda: torques(guess=np.zeros(0)))
case("path_coefficients: valid", "alpha:ok", lambda: model.path_coefficients(states, states * 0, states * 0, q0))
case("path_coefficients: d1 of 1 column", "d1", lambda: model.path_coefficients(states, np.zeros((3, 1)), states, q0))
case("path_coefficients: NaN d2", "d2", lambda: model.path_coefficients(states, states, np.full((3, DOF), NAN), q0))
""",
    "analytic_plant": """
plant = build_core_analytic_plant(dp.AnalyticPlant(dp.load_delta()))
x = np.array([0.3, 0.3, 0.3, 0.0, 0.0, 0.0])
tau = np.zeros(3)
def settings(integrator="rk4", samples=5, substeps=2, dt=1e-3):  # the run's settings by name
    made = m.RunSettings()
    made.integrator, made.samples, made.substeps, made.dt = integrator, samples, substeps, dt
    return made
def sampled(x=x, samples=5, substeps=2, dt=1e-3, control=None, integrator="rk4", **continuous):
    control = (lambda k, state, alpha, alpha_dot: np.zeros(3)) if control is None else control
    made = settings(integrator, samples, substeps, dt)
    return m.run(plant, control, made, x, m.RunRecords(), **continuous)
case("derivative of an empty state", "x", lambda: plant.derivative(np.zeros(0), tau, 0.0))
case("derivative under a 2-vector torque", "tau", lambda: plant.derivative(x, np.zeros(2), 0.0))
case("derivative of a state of 5", "x", lambda: plant.derivative(x[:5].copy(), tau, 0.0))
case("derivative at NaN", "x", lambda: plant.derivative(np.full(6, NAN), tau, 0.0))
case("derivative under a NaN torque", "tau", lambda: plant.derivative(x, np.full(3, NAN), 0.0))
case("derivative at a NaN row", "row", lambda: plant.derivative(x, tau, NAN))
def strided():  # x[::2] of a 12-vector is x
    wide = np.repeat(x, 2)
    assert np.array_equal(plant.derivative(wide[::2], tau, 0.0), plant.derivative(x, tau, 0.0))
case("derivative of a non-contiguous x", "x:ok", strided)
case("end_effector_position of an empty q", "q", lambda: plant.end_effector_position(np.zeros(0)))
case("closure_gap of an empty q", "q", lambda: plant.closure_gap(np.zeros(0)))
case("step: empty x", "x", lambda: plant.step(np.zeros(0), tau, 0, 1e-3))
case("step: NaN h", "h", lambda: plant.step(x, tau, 0, NAN))
case("step: NaN tau", "tau", lambda: plant.step(x, np.full(3, NAN), 0, 1e-3))
def friction(normal_forces):  # eq. 12's friction by name, as the package builds it
    f = m.StribeckFriction()
    f.r_a, f.v_s, f.mu_s, f.mu_d, f.mu_v, f.sign_scale, f.normal_force = 0.0, 0.1, 0.1, 0.1, 0.1, 0.01, np.zeros(normal_forces)
    return f
case("set_friction: 2 normal forces", "normal_force", lambda: plant.set_friction(friction(2)))
case("set_truth: normal forces of 2 columns", "normal_forces", lambda: plant.set_truth(1e-3, np.zeros(0), np.zeros((4, 2)), np.zeros((0, 3))))
case("run: empty x", "x", lambda: sampled(x=np.zeros(0)))
case("run: NaN x", "x", lambda: sampled(x=np.full(6, NAN)))
case("run: samples 0", "samples", lambda: sampled(samples=0))
case("run: samples -2", "samples", lambda: sampled(samples=-2))
case("run: substeps 0", "substeps", lambda: sampled(substeps=0))
case("run: dt NaN", "dt", lambda: sampled(dt=NAN))
case("run: dt 0", "dt", lambda: sampled(dt=0.0))
case("run: a torque of 2", "torque", lambda: sampled(control=lambda k, state, alpha, alpha_dot: np.zeros(2)))
case("run: integrator 'euler'", "integrator", lambda: sampled(integrator="euler"))
case("run: a sampled run given z0", "z0", lambda: sampled(z0=np.zeros(1)))
case("run: a law that is a number", "law", lambda: sampled(control=3.0))
case("run: a callable law in continuous mode", "integrator", lambda: sampled(
    integrator="radau", z0=np.zeros(0), reference=m.HermiteReference()))
case("run: a list x", "x0:TypeError", lambda: sampled(x=[0.3, 0.3, 0.3, 0.0, 0.0, 0.0]))
case("constructor: NaN R", "R", lambda: m.AnalyticDeltaPlant(NAN, 0.1, 0.2, 0.3, 1e-3, 0.1, 9.81, np.ones(3), np.zeros(3), 0.1, 0.1))
""",
    "closed_chain_plant": """
import pinocchio as pin
python_plant = dp.ClosedChainPlant(robot)
plant = build_core_plant(python_plant)
x = np.concatenate([q0, np.zeros(NV)])
tau = np.zeros(DOF)
cm = python_plant.constraint_models[0]
def constraint(size=3, j1=int(cm.joint1_id), j2=int(cm.joint2_id), frame=int(cm.reference_frame)):
    return (size, j1, cm.joint1_placement.homogeneous, j2, cm.joint2_placement.homogeneous, frame)
def build(*constraints):
    made = m.ClosedChainPlant(chain, list(constraints), 10.0, 10.0, 1e-12, 0.0, 10, 1e-8)
    made.accelerations(q0, np.zeros(NV), tau, 0.0)
def sampled(x=x, samples=5, substeps=2, dt=1e-3):
    made = m.RunSettings()
    made.samples, made.substeps, made.dt = samples, substeps, dt
    return m.run(plant, lambda k, state, alpha, alpha_dot: np.zeros(DOF), made, x, m.RunRecords())
case("constraint of 0 rows", "constraints", lambda: build(constraint(size=0)))
case("constraint of -3 rows", "constraints", lambda: build(constraint(size=-3)))
case("constraint joint = njoints", "constraints", lambda: build(constraint(j2=NJ)))
case("constraint joint -1", "constraints:TypeError", lambda: build(constraint(j1=-1)))
case("constraint reference frame 7", "constraints", lambda: build(constraint(frame=7)))
case("constraint reference frame -1", "constraints", lambda: build(constraint(frame=-1)))
case("springs: q entry = nq", "q_index", lambda: use(describe(springs=springs([NQ], [0], [1.0], [0.0], [0.0]))))
case("springs: v entry -1", "v_index", lambda: use(describe(springs=springs([0], [-1], [1.0], [0.0], [0.0]))))
case("springs: 2 stiffnesses for 1 spring", "k", lambda: use(describe(springs=springs([0], [0], [1.0, 1.0], [0.0], [0.0]))))
case("springs: damper entry = nv", "damper_v", lambda: use(describe(springs=springs(damper_v=[NV], damper_d=[1.0]))))
case("springs: 1 damping for 2 dampers", "damper_d", lambda: use(describe(springs=springs(damper_v=[0, 1], damper_d=[1.0]))))
case("springs: NaN stiffness", "finite", lambda: use(describe(springs=springs([0], [0], [NAN], [0.0], [0.0]))))
case("set_truth: joint = njoints", "joint", lambda: plant.set_truth(NJ, np.zeros(3), 1e-3, np.zeros(0), np.zeros(1), np.zeros((0, DOF)), np.zeros((0, DOF))))
case("set_truth: disturbance of 3 columns", "disturbances", lambda: plant.set_truth(1, np.zeros(3), 1e-3, np.zeros(0), np.zeros(1), np.zeros((0, DOF)), np.zeros((4, 3))))
case("accelerations: empty q", "q", lambda: plant.accelerations(np.zeros(0), np.zeros(NV), tau, 0.0))
case("accelerations: tau of 3", "tau", lambda: plant.accelerations(q0, np.zeros(NV), np.zeros(3), 0.0))
case("accelerations: NaN v", "v", lambda: plant.accelerations(q0, np.full(NV, NAN), tau, 0.0))
case("step: empty x", "x", lambda: plant.step(np.zeros(0), tau, 0, 1e-3))
case("step: NaN x", "x", lambda: plant.step(np.full(NQ + NV, NAN), tau, 0, 1e-3))
case("step: h 0", "h", lambda: plant.step(x, tau, 0, 0.0))
case("end_effector_position: empty q", "q", lambda: plant.end_effector_position(np.zeros(0)))
case("closure_gap: empty q", "q", lambda: plant.closure_gap(np.zeros(0)))
case("run: x of nq", "x", lambda: sampled(x=q0.copy()))
case("run: NaN x", "x", lambda: sampled(x=np.full(NQ + NV, NAN)))
case("run: non-contiguous x", "x:ok", lambda: sampled(x=np.repeat(x, 2)[::2]))
case("derivative: x of nq", "x", lambda: plant.derivative(q0.copy(), tau, 0.0))
case("derivative: tau of 3", "tau", lambda: plant.derivative(x, np.zeros(3), 0.0))
case("derivative: NaN row", "row", lambda: plant.derivative(x, tau, NAN))
case("failure_tolerance 0", "failure_tolerance", lambda: plant.set_failure_tolerance(0.0, " m"))
case("failure_tolerance NaN", "failure_tolerance", lambda: plant.set_failure_tolerance(NAN, " m"))
def active_run(x=x):
    made = build_core_plant(python_plant)
    made.integrates_active = True
    settings = m.RunSettings()
    settings.samples, settings.dt = 5, 1e-3
    return m.run(made, lambda k, state, alpha, alpha_dot: np.zeros(DOF), settings, x, m.RunRecords())
case("active run: x of nq", "x", lambda: active_run(x=q0.copy()))
case("active run: NaN x", "x", lambda: active_run(x=np.full(NQ + NV, NAN)))
case("active run: non-contiguous x", "x:ok", lambda: active_run(x=np.repeat(x, 2)[::2]))
""",
    "laws": """
zeros, ones = np.zeros(DOF), np.ones(DOF)
from delta_pin.control.nominal import named_gains
def gains(kind, **fields):
    return named_gains(m, kind, fields)
def ct(D=ones, T_p=ones, T_v=ones):
    return gains("ComputedTorque", D=D, T_p=T_p, T_v=T_v)
def law():
    return m.ComputedTorque(m.ProjectedTerms(chain, q0), zeros, "ct", ct())
def drive(**fields):  # the encoder and drive by name, as the package builds them
    settings = m.DriveSettings()
    settings.noise = np.zeros((0, DOF))
    for name, value in fields.items():
        setattr(settings, name, value)
    return settings
def table(rows, cols=DOF):
    return np.tile(alpha0, (rows, 1))[:, :cols].copy(), np.zeros((rows, cols)), np.zeros((rows, cols))
python_plant = dp.ClosedChainPlant(robot)
plant = build_core_plant(python_plant)
x = np.concatenate([q0, np.zeros(NV)])
def run(controller, samples=5):
    made = m.RunSettings()
    made.samples, made.dt = samples, 1e-3
    return m.run(plant, controller, made, x, m.RunRecords())
case("ComputedTorque: reference configuration of 3", "reference_configuration", lambda: m.ComputedTorque(m.ProjectedTerms(chain, np.zeros(3)), zeros, "ct", ct()))
case("ComputedTorque: D of 3", "D", lambda: m.ComputedTorque(m.ProjectedTerms(chain, q0), zeros, "ct", ct(D=np.ones(3))))
case("ComputedTorque: chain with a closure of 0 rows", "closures", lambda: m.ComputedTorque(
    m.ProjectedTerms(describe(closures=[(FRAMES[0][0], FRAMES[0][1], 0)]), q0), zeros, "ct", ct()).evaluate(alpha0, zeros, alpha0, zeros, zeros, np.zeros(0)))
case("PythonTerms: dof 0", "dof", lambda: m.PythonTerms(0, lambda a, v: None, lambda v: None))
case("PythonTerms: terms not callable", "terms:TypeError", lambda: m.PythonTerms(DOF, None, lambda v: zeros))
case("ComputedTorque: disturbance of 3 on a Python model", "disturbance", lambda: m.ComputedTorque(
    m.PythonTerms(DOF, lambda a, v: (np.eye(DOF), np.zeros((DOF, DOF)), zeros), lambda v: zeros), np.zeros(3), "ct", ct()))
case("evaluate: a Python model's terms return None", "terms", lambda: m.ComputedTorque(
    m.PythonTerms(DOF, lambda a, v: None, lambda v: zeros), zeros, "ct", ct()).evaluate(alpha0, zeros, alpha0, zeros, zeros, np.zeros(0)))
case("evaluate: a Python model's compensation of 3", "compensation", lambda: m.ComputedTorque(
    m.PythonTerms(DOF, lambda a, v: (np.eye(DOF), np.zeros((DOF, DOF)), zeros), lambda v: np.zeros(3)), zeros, "ct", ct()
    ).evaluate(alpha0, zeros, alpha0, zeros, zeros, np.zeros(0)))
case("PDGravity: K_d empty", "K_d", lambda: m.PDGravity(m.ProjectedTerms(chain, q0), zeros, "pd", gains("PDGravity", K_p=ones, K_d=np.zeros(0))))
case("TimeDelayControl: delay -1", "delay", lambda: m.TimeDelayControl(m.ProjectedTerms(chain, q0), zeros, "tdc", gains(
    "TimeDelayControl", period=1e-3, K_p=1.0, K_v=1.0, delay=-1, mean_pairing=False)))
case("LQR: gain of n x n", "gain", lambda: m.LQR(m.ProjectedTerms(chain, q0), zeros, "lqr", gains(
    "LQR", alpha0=alpha0, gravity=zeros, gravity_slope=np.eye(DOF), inertia=np.eye(DOF), gain=np.eye(DOF))))
case("evaluate: alpha of 3", "alpha", lambda: law().evaluate(np.zeros(3), zeros, alpha0, zeros, zeros, np.zeros(0)))
case("evaluate: NaN ref_alpha_ddot", "ref_alpha_ddot", lambda: law().evaluate(alpha0, zeros, alpha0, zeros, np.full(DOF, NAN), np.zeros(0)))
def started(samples, reference, **drive):
    controller = law()
    controller.start(*reference, 1e-3, np.zeros(0), samples)
    return controller
case("start: an empty reference table", "alpha_d", lambda: started(5, table(0)))
case("start: reference of 1 column", "alpha_d", lambda: started(5, table(5, 1)))
case("start: samples -1", "samples", lambda: started(-1, table(5)))
case("start: dt 0", "dt", lambda: law().start(*table(5), 0.0, np.zeros(0), 5))
case("start: dt NaN", "dt", lambda: law().start(*table(5), NAN, np.zeros(0), 5))
def discrete_in_continuous_mode():
    tdc = m.TimeDelayControl(m.ProjectedTerms(chain, q0), zeros, "tdc", gains(
        "TimeDelayControl", period=1e-3, K_p=1.0, K_v=1.0, delay=1, mean_pairing=False))
    made = m.RunSettings()
    made.integrator = "radau"
    m.run(plant, tdc, made, x, m.RunRecords(), np.zeros(0), m.HermiteReference())
case("a discrete-time law in continuous mode", "continuous face", discrete_in_continuous_mode)
case("run past the samples of start()", "samples", lambda: run(started(3, table(3))))
def driven(samples=5, **fields):  # a sampled run of the law through a drive of these settings
    made = m.RunSettings()
    made.samples, made.dt, made.drive = samples, 1e-3, drive(**fields)
    return m.run(plant, started(samples, table(samples)), made, x, m.RunRecords())
case("drive: noise of 1 row for 5 samples", "noise", lambda: driven(sensor=True, resolution=1e-4, noise=np.zeros((1, DOF))))
case("drive: noise of 3 columns", "noise", lambda: driven(sensor=True, resolution=1e-4, noise=np.zeros((5, 3))))
case("drive: resolution 0", "resolution", lambda: driven(sensor=True, resolution=0.0))
case("drive: resolution NaN", "resolution", lambda: driven(sensor=True, resolution=NAN))
case("drive: delay -1", "delay", lambda: driven(exact_velocity=True, drive=True, delay=-1))
case("drive: torque limit of 3", "torque_limit", lambda: driven(drive=True, torque_limit=np.ones(3)))
def drive_in_continuous_mode():
    made = m.RunSettings()
    made.integrator, made.drive = "radau", drive(drive=True, delay=1)
    m.run(plant, law(), made, x, m.RunRecords(), np.zeros(0), m.HermiteReference())
case("a drive in continuous mode", "drive", drive_in_continuous_mode)
case("drive: a valid one", "noise:ok", lambda: driven(sensor=True, resolution=1e-4, noise=np.zeros((5, DOF)), drive=True, delay=2))
def friction(normal_forces):  # eq. 12's friction by name, as the package builds it
    f = m.StribeckFriction()
    f.r_a, f.v_s, f.mu_s, f.mu_d, f.mu_v, f.sign_scale, f.normal_force = 0.0, 0.1, 0.1, 0.1, 0.1, 0.01, np.zeros(normal_forces)
    return f
case("set_friction: 3 normal forces", "normal_force", lambda: law().set_friction(friction(3)))
""",
    "continuous": """
analytic = build_core_analytic_plant(dp.AnalyticPlant(dp.load_delta()))
a0 = np.array([0.3, 0.3, 0.3])
class Law:
    def evaluate(self, t, q, alpha, alpha_dot, ref_alpha, ref_alpha_dot, ref_alpha_ddot, z):
        return np.zeros(3), np.zeros(0)
    def keep(self, k, tau, z):
        pass
def reference(rows, cols=3, dddot_rows=None):
    dddot_rows = rows if dddot_rows is None else dddot_rows
    return np.tile(a0[:cols], (rows, 1)), np.zeros((rows, cols)), np.zeros((rows, cols)), np.zeros((dddot_rows, cols))
def go(tables=None, step=1e-3, alpha0=a0, dt=1e-3, samples=5, rtol=1e-8, atol=1e-10, first=1e-5, max_step=1e-2, plant=analytic, integrator="radau", substeps=1):
    tables = reference(10) if tables is None else tables
    settings = m.RunSettings()
    settings.integrator, settings.substeps = integrator, substeps
    settings.dt, settings.samples, settings.rtol, settings.atol = dt, samples, rtol, atol
    settings.first_step, settings.max_step, settings.max_joint_speed = first, max_step, 100.0
    table = m.HermiteReference()
    table.step = step
    table.alpha, table.alpha_dot, table.alpha_ddot, table.alpha_dddot = tables
    run = m.RunRecords()
    m.run(plant, Law(), settings, np.concatenate([alpha0, np.zeros(3)]), run, np.zeros(0), table)
    return run
case("valid", "alpha:ok", lambda: go())
case("an empty reference table", "alpha", lambda: go(tables=reference(0)))
case("reference of 2 columns", "alpha", lambda: go(tables=reference(10, 2)))
case("alpha_dddot of fewer rows", "alpha_dddot", lambda: go(tables=reference(10, dddot_rows=2)))
case("step 0", "step", lambda: go(step=0.0))
case("step NaN", "step", lambda: go(step=NAN))
case("x0 of 5", "x0", lambda: go(alpha0=np.zeros(2)))
case("bdf2: substeps 0", "substeps", lambda: go(integrator="bdf2", substeps=0))
case("a continuous law in sampled mode", "sampled", lambda: m.run(
    analytic, Law(), m.RunSettings(), np.concatenate([a0, np.zeros(3)]), m.RunRecords()))
def radau():
    made = m.RunSettings()
    made.integrator = "radau"
    return made
case("without a reference", "reference", lambda: m.run(
    analytic, Law(), radau(), np.concatenate([a0, np.zeros(3)]), m.RunRecords(), np.zeros(0)))
case("samples 0", "samples", lambda: go(samples=0))
case("max_step 0", "max_step", lambda: go(max_step=0.0))
case("rtol NaN", "rtol", lambda: go(rtol=NAN))
case("non-contiguous alpha", "alpha:ok", lambda: go(tables=(np.tile(a0, (20, 1))[::2],) + reference(10)[1:]))
""",
}


def _run(group: str) -> tuple[subprocess.CompletedProcess, list[dict]]:
    code = textwrap.dedent(PRELUDE) + textwrap.dedent(GROUPS[group])
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    lines = [json.loads(line) for line in done.stdout.splitlines() if line.startswith("{")]
    return done, lines


def _cases(group: str) -> int:
    return GROUPS[group].count('\ncase("')


@pytest.fixture(scope="module")
def needs_core():
    from delta_pin.compiled.core import core

    try:
        return core()
    except Exception as exc:
        pytest.skip(f"the compiled core is unavailable: {exc}")


@pytest.mark.parametrize("group", sorted(GROUPS))
def test_every_bad_call_is_a_value_error_naming_the_argument(needs_core, group):
    done, lines = _run(group)
    last = lines[-1]["case"] if lines else "(none)"
    assert done.returncode >= 0, (
        f"{group}: killed by signal {-done.returncode} after case {last!r}\n{done.stderr[-3000:]}"
    )
    assert done.returncode == 0, f"{group}: exit {done.returncode}\n{done.stderr[-3000:]}"
    assert len(lines) == _cases(group), f"{group}: {len(lines)} of {_cases(group)} cases reported"
    wrong = []
    for line in lines:
        arg, _, expected = line["arg"].partition(":")
        expected = expected or "ValueError"
        if line["outcome"] != expected:
            wrong.append(f"{line['case']}: {line['outcome']} (expected {expected}) {line['message'][:300]}")
        elif expected != "ok" and arg not in line["message"]:
            wrong.append(f"{line['case']}: the message does not name {arg!r}: {line['message'][:300]}")
    assert not wrong, "\n".join(wrong)
