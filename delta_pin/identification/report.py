"""What ``delta-pin identify fit`` writes (every file atomically):

* ``parameters.json`` -- the base parameters (name, combination of standard parameters, WLS value,
  standard deviation, OLS value, the consistent estimate's value), the rank decision, the fit's
  residual, condition number and timings, the friction per joint (``friction``: the bounded fit,
  physical by construction; ``friction_unconstrained``: WLS beside it), for a Delta the paper's lumped
  terms and the ``xacro_arguments`` of the identified robot, the physically consistent standard
  parameters per body, the base parameters the essential fit set to 0 (``dropped``: name, t value),
  a validation on an unseen log where one was given (every row and away from velocity reversals,
  per joint), the log's torque
  against the CAD model's (``torque_scale``) and the fit's ``warnings`` (also atop report.md);
* ``xacro_arguments.json`` (a Delta) -- ``load_delta(**json.load(...))`` or
  ``delta-pin urdf --set m_a=... ...`` builds the identified robot;
* ``robot.urdf`` (a robot from a URDF) -- the robot's URDF with the physically consistent
  inertials (``dp.load_robot`` reads it back), only where that estimate converged (its status,
  :func:`consistent_status`, is in report.md, parameters.json's ``consistent`` and stdout);
* ``report.md`` and the figures ``torque.png`` (measured vs predicted torque), ``residual.png``
  (residual histogram per joint) and ``condition.png`` (singular values of the column-scaled base
  regressor of the log).

**No file of anyone else's is ever replaced.** These seven names (:data:`OUTPUTS`) are the fit's
outputs, whichever of them a fit writes (``xacro_arguments.json`` only for a Delta,
``robot.urdf`` only where identified, the figures only with ``figures=True``); nothing else in
the folder (a user's notes, a ``figures/`` folder, the log) is read, listed or removed. The rule
is ``delta-pin run``'s (:func:`delta_pin.utils.manifest.claim` with ``outputs=OUTPUTS``,
``replace_same_command=True``, command :data:`COMMAND`): each of the names present must be listed
by the folder's ``manifest.json`` as an earlier ``identify fit``'s output, unchanged since (its
SHA-256), and is then replaced whatever that fit's options; any other file of those names (a
Gepetto folder's CAD ``robot.urdf``, a user's ``report.md``) is refused in one line, as is a
folder another process is writing (its lock) or another command's folder. ``delta-pin identify
fit`` claims ``--out`` so, and :func:`write_report` claims ``out`` the same way when it is not
given a claimed folder (``folder=``): one rule for the command and for Python. The folder is
marked ``"complete": false`` before its first file, each file is listed as it is written, and it
is complete once the last is.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from delta_pin.errors import InvalidParameterError
from delta_pin.identification.log import IdentificationLog
from delta_pin.identification.workflow import IdentificationResult
from delta_pin.utils.atomic import atomic_open, write_text_atomically
from delta_pin.utils.manifest import OutputFolder, claim

__all__ = [
    "COMMAND",
    "OUTPUTS",
    "consistent_status",
    "identified_urdf",
    "parameters_record",
    "validation_summary",
    "write_report",
]

COMMAND = "identify fit"  # the command a fit's manifest.json names
# every name a fit may write into its folder (module docstring): only these must be its own
OUTPUTS = (
    "parameters.json",
    "xacro_arguments.json",
    "robot.urdf",
    "report.md",
    "torque.png",
    "residual.png",
    "condition.png",
)


def _float(x) -> float | None:
    x = float(x)
    return x if np.isfinite(x) else None


def parameters_record(result: IdentificationResult, validation: dict | None = None) -> dict:
    """``parameters.json``'s content (module docstring)."""
    base = result.base
    kept, dropped = base.gap
    consistent = result.consistent
    regressor = result.regressor
    rows = []
    for i, name in enumerate(result.names):
        rows.append(
            {
                "name": name,
                "combination": result.expressions[i],
                "wls": _float(result.wls.beta[i]),
                "std": _float(result.wls.std[i]),
                "ols": _float(result.ols.beta[i]),
                "bounded": None if result.bounded_beta is None else _float(result.bounded_beta[i]),
                "consistent": None if consistent is None else _float(consistent.beta[i]),
                "nominal": _float(base.values(result.theta_nominal)[i]),
            }
        )
    record = {
        "robot": regressor.robot.name,
        "joints": list(regressor.robot.actuated_joints),
        "columns": {
            "kinds": [prefix for prefix, _ in regressor.columns.kinds()],
            "stribeck_velocity": regressor.columns.stribeck_velocity,
            "friction_arm": regressor.columns.friction_arm,
            "sign_velocity_scale": regressor.columns.sign_velocity_scale,
        },
        "fixed_bodies": list(regressor.fixed_bodies),
        "rank": {
            "base_parameters": base.rank,
            "standard_parameters": regressor.size,
            "rtol": base.rtol,
            "smallest_kept": kept,
            "largest_dropped": dropped,
            "absent": [base.names[k] for k in base.absent],
        },
        "base_parameters": rows,
        # the essential fit's zeros (docs/identification.md section 4): each base parameter set to 0,
        # in the order they went, with its |beta| / sigma when it went
        "dropped": [{"name": name, "t": _float(t)} for name, t in result.dropped],
        "fit": {
            "samples": result.samples,
            "cutoff_hz": result.cutoff,
            "condition": result.condition,
            "residual_rms": result.residual_rms.tolist(),
            "residual_relative": (result.residual_rms / result.tau_rms).tolist(),
            "timings_s": result.timings,
        },
        "friction": {k: [_float(x) for x in v] for k, v in result.friction.items()},
        "friction_unconstrained": {
            k: [_float(x) for x in v] for k, v in result.friction_unconstrained.items()
        },
        "torque_scale": {k: v if isinstance(v, str) else _float(v) for k, v in result.torque_scale.items()},
        "warnings": list(result.warnings),
        "notes": list(result.notes),
        "velocities": result.velocities,
        "velocity_lag_s": None if result.velocity_lag is None else [_float(x) for x in result.velocity_lag],
    }
    if consistent is not None:
        bodies = {}
        from delta_pin.identification.regressor import INERTIAL_NAMES

        for i, body in enumerate(regressor.body_names):
            bodies[body] = dict(
                zip(INERTIAL_NAMES, consistent.theta[10 * i : 10 * i + 10].tolist(), strict=True)
            )
        record["consistent"] = {
            "bodies": bodies,
            "distance_mahalanobis": consistent.distance_mahalanobis,
            "distance_relative": consistent.distance_relative,
            "min_pseudo_inertia_eigenvalue": consistent.min_eigenvalues.tolist(),
            "success": consistent.success,
            "converged": consistent.success,
            "message": consistent.message,
            "iterations": consistent.iterations,
            "duality_gap": _float(consistent.duality_gap),
            "time_s": result.timings.get("consistent"),
        }
    if result.lumped is not None:
        record["lumped"] = dict(zip(result.lumped["names"], result.lumped["values"], strict=True))
        record["lumped_span_residual"] = result.lumped["span_residual"]
        record["xacro_arguments"] = result.xacro_arguments
    if validation is not None:
        record["validation"] = _plain(validation)
    return record


def _plain(value):
    """``value`` with every non-finite float as ``None`` (strict JSON)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float):
        return _float(value)
    return value


def validation_summary(validation: dict) -> str:
    """One line: the unseen-torque error RMS per joint over every row and away from velocity
    reversals (:func:`~delta_pin.identification.workflow.validate`), relative to the torque's RMS."""

    def joints(values):
        return ", ".join("n/a" if x is None or not np.isfinite(x) else f"{x:.3g}" for x in values)

    mask = validation["reversal_mask"]
    near = ", ".join(f"{100 * x:.0f} %" for x in mask["fraction_near"])
    return (
        f"validation: torque error RMS {joints(validation['rms_relative'])} relative (every row); "
        f"{joints(validation['away_from_reversals']['rms_relative'])} away from velocity reversals "
        f"(rows with |qd_j| >= {mask['speed']:g} rad/s for {mask['window_s']:g} s either side, the "
        f"fit's reversal mask; near: {near} of the rows)"
    )


def consistent_status(result: IdentificationResult) -> str:
    """One line: whether the consistent estimate converged, the solver's message and steps, and
    whether robot.urdf is written from it (``""`` where it was not computed)."""
    c = result.consistent
    if c is None:
        return ""
    seconds = result.timings.get("consistent", float("nan"))
    if c.success:
        return f"consistent estimate: converged ({c.message}, {seconds:.2f} s)"
    return (
        f"consistent estimate: NOT converged ({c.message}, {seconds:.2f} s); robot.urdf is not written "
        "(the WLS base parameters are not standard parameters a URDF can hold)"
    )


def identified_urdf(result: IdentificationResult) -> str | None:
    """The identified robot as a URDF that ``load_robot`` reads back with its motors, masses,
    friction and rotor inertia, or ``None`` where there is none to hand on: written only where the
    physically consistent estimate converged (``result.consistent.success``), for any robot.

    * A Delta (``robot.delta``): the packaged xacro compiled at the robot's dimensions and the
      identified ``xacro_arguments`` (masses; eq. 12's friction where identified), so that it is
      recognised as a Delta and carries the analytic model; ``None`` where an identified mass is
      not positive (fitted lumped terms no Delta has).
    * Any other robot with URDF text: its URDF with every moving link's inertial replaced by the
      consistent estimate (mass, COM, inertia about the COM in the link frame), each
      actuated joint's ``<dynamics damping="fv" friction="fc">`` [N m s/rad, N m] and its rotor
      inertia as Drake's ``<drake:rotor_inertia>`` in the joint's ``<transmission>`` (added where the
      file had none, so that ``load_robot`` finds the motors without ``actuated=``; delta-pin reads
      it into ``model.armature``). ``None`` where a body gathers several links (fixed joints).
    """
    if result.consistent is None or not result.consistent.success:
        return None
    if result.xacro_arguments is not None and result.regressor.robot.delta is not None:
        return _identified_delta_urdf(result)
    if not result.regressor.robot.urdf:
        return None
    from lxml import etree

    regressor = result.regressor
    try:
        root = etree.fromstring(regressor.robot.urdf.encode())
    except etree.XMLSyntaxError:
        return None
    links = {link.get("name"): link for link in root.iter("link")}
    for i, body in enumerate(regressor.body_names):
        link = links.get(body)
        if link is None:
            return None
        m, hx, hy, hz, ixx, ixy, iyy, ixz, iyz, izz = result.consistent.theta[10 * i : 10 * i + 10]
        c = np.array([hx, hy, hz]) / m
        inertia = np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]])
        # about the COM (parallel axis theorem): I_c = I_o - m (|c|^2 1 - c c^T)
        inertia_c = inertia - m * (c @ c * np.eye(3) - np.outer(c, c))
        for old in link.findall("inertial"):
            link.remove(old)
        inertial = etree.SubElement(link, "inertial")
        etree.SubElement(inertial, "origin", xyz=" ".join(f"{x:.12g}" for x in c), rpy="0 0 0")
        etree.SubElement(inertial, "mass", value=f"{m:.12g}")
        etree.SubElement(inertial, "inertia", ixx=f"{inertia_c[0, 0]:.12g}", ixy=f"{inertia_c[0, 1]:.12g}",
                         ixz=f"{inertia_c[0, 2]:.12g}", iyy=f"{inertia_c[1, 1]:.12g}",
                         iyz=f"{inertia_c[1, 2]:.12g}", izz=f"{inertia_c[2, 2]:.12g}")  # fmt: skip
    joint_values = dict(zip(regressor.names, result.consistent.theta, strict=True))
    _write_joint_friction(root, regressor.robot.actuated_joints, joint_values)
    _write_transmissions(root, regressor.robot.actuated_joints, joint_values)
    return etree.tostring(root, pretty_print=True, xml_declaration=True, encoding="utf-8").decode()


def _identified_delta_urdf(result: IdentificationResult) -> str | None:
    """The packaged xacro at the robot's dimensions and the identified masses and friction."""
    from delta_pin.errors import XacroArgumentError
    from delta_pin.model.description import compile_urdf

    p = result.regressor.robot.delta.params
    args: dict[str, float | str] = {"R": p.R, "r": p.r, "l_a": p.l_a, "l_b": p.l_b}
    args["forearm_inertia"] = p.forearm_inertia
    if p.friction is not None:
        f = p.friction
        args.update(r_a=f.r_a, v_s=f.v_s, mu_s=f.mu_s, mu_d=f.mu_d, mu_v=f.mu_v)
    columns = result.regressor.columns
    if columns.stribeck_velocity is not None and p.friction is not None:
        args.update(v_s=columns.stribeck_velocity, r_a=columns.friction_arm)  # the fit's exponent
    args.update(result.xacro_arguments)
    masses = np.array([args["m_a"], args["m_b"], args["m_o"]], dtype=float)
    if not (np.isfinite(masses).all() and (masses > 0.0).all()):
        return None
    try:
        return compile_urdf(**args)
    except XacroArgumentError:  # e.g. an identified friction coefficient below 0
        return None


_DRAKE = "http://drake.mit.edu"  # Drake's URDF extensions (drake:rotor_inertia, drake:gear_ratio)


def _write_joint_friction(root, joints, values: dict) -> None:
    """``<dynamics damping="fv" friction="fc">`` on each actuated joint where the fit has them
    (URDF's own viscous [N m s/rad] and Coulomb [N m] friction; other attributes kept)."""
    from lxml import etree

    elements = {joint.get("name"): joint for joint in root.iter("joint")}
    for name in joints:
        fv, fc = values.get(f"fv[{name}]"), values.get(f"fc[{name}]")
        if name not in elements or (fv is None and fc is None):
            continue
        dynamics = elements[name].find("dynamics")
        if dynamics is None:
            dynamics = etree.SubElement(elements[name], "dynamics")
        if fv is not None:
            dynamics.set("damping", f"{fv:.12g}")
        if fc is not None:
            dynamics.set("friction", f"{fc:.12g}")


def _write_transmissions(root, joints, values: dict) -> None:
    """A ``<transmission>`` per actuated joint the file did not already drive (ROS's simple
    transmission, which load_robot reads as the joint's motor), and the identified rotor inertia
    ``Ia`` in each actuator as Drake's ``<drake:rotor_inertia>`` (divided by the square of the
    actuator's ``<drake:gear_ratio>`` where it has one: Drake reflects I N^2)."""
    from lxml import etree

    rotor, ratio_tag = f"{{{_DRAKE}}}rotor_inertia", f"{{{_DRAKE}}}gear_ratio"
    driven = {j.get("name"): t for t in root.iter("transmission") for j in t.iter("joint")}
    for joint in joints:
        transmission = driven.get(joint)
        if transmission is None:
            transmission = etree.SubElement(root, "transmission", name=f"{joint}_transmission")
            etree.SubElement(transmission, "type").text = "transmission_interface/SimpleTransmission"
            element = etree.SubElement(transmission, "joint", name=joint)
            etree.SubElement(element, "hardwareInterface").text = "hardware_interface/EffortJointInterface"
            actuator = etree.SubElement(transmission, "actuator", name=f"{joint}_motor")
            etree.SubElement(actuator, "mechanicalReduction").text = "1"
        inertia = values.get(f"Ia[{joint}]")
        actuator = transmission.find("actuator")
        if inertia is None or actuator is None:
            continue
        ratio = actuator.find(ratio_tag)
        n = 1.0 if ratio is None else float(ratio.get("value", "1"))
        for old in actuator.findall(rotor):
            actuator.remove(old)
        etree.SubElement(actuator, rotor, nsmap={"drake": _DRAKE}, value=f"{inertia / (n * n):.12g}")


def _figures(result: IdentificationResult, log: IdentificationLog, out: Path, wrote=None) -> list[Path]:
    """The three figures, each passed to ``wrote`` (if given) as soon as it is saved."""
    from matplotlib.figure import Figure

    def saved(path: Path) -> Path:
        if wrote is not None:
            wrote(path)
        return path

    predicted, measured = result.predict(log)
    t = log.t[: len(predicted)]
    trim = (log.t >= log.t[0] + 0.05) & (log.t <= log.t[-1] - 0.05)
    t = log.t[trim]
    joints = result.regressor.robot.actuated_joints
    written = []
    fig = Figure(figsize=(9, 2.2 * len(joints)))
    axes = fig.subplots(len(joints), 1, sharex=True, squeeze=False)[:, 0]
    for j, ax in enumerate(axes):
        ax.plot(t, measured[:, j], lw=0.8, label="measured (filtered)")
        ax.plot(t, predicted[:, j], lw=0.8, ls="--", label="predicted (WLS)")
        ax.set_ylabel(f"tau[{joints[j]}] [N m]")
    axes[0].legend(loc="upper right")
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    written.append(saved(_save(fig, out / "torque.png")))
    fig = Figure(figsize=(9, 3))
    ax = fig.subplots()
    for j in range(len(joints)):
        ax.hist(measured[:, j] - predicted[:, j], bins=60, histtype="step", label=joints[j])
    ax.set_xlabel("measured - predicted torque [N m]")
    ax.set_ylabel("samples")
    ax.legend()
    fig.tight_layout()
    written.append(saved(_save(fig, out / "residual.png")))
    fig = Figure(figsize=(9, 3))
    ax = fig.subplots()
    ax.semilogy(np.arange(1, len(result.singular_values) + 1), result.singular_values, "o-", ms=3)
    ax.set_xlabel("singular value index")
    ax.set_ylabel("sigma_i / sigma_1")
    ax.set_title(f"column-scaled base regressor of the log: cond = {result.condition:.4g}")
    fig.tight_layout()
    written.append(saved(_save(fig, out / "condition.png")))
    return written


def _save(fig, path: Path) -> Path:
    with atomic_open(path, "wb") as handle:
        fig.savefig(handle, format="png", dpi=110)
    return path


def write_report(
    result: IdentificationResult, log: IdentificationLog, out: str | Path, validation: dict | None = None,
    figures: bool = True, *, folder: OutputFolder | None = None,
) -> list[Path]:  # fmt: skip
    """Write the module docstring's files into the folder ``out``; returns their paths.

    Args:
        folder: ``out`` as :func:`delta_pin.utils.manifest.claim` locked it for :data:`COMMAND`
            with ``outputs=OUTPUTS`` (what ``delta-pin identify fit`` passes, recording its
            options); ``None``: claimed here the same way (its options: none). Either way it is
            marked incomplete and the earlier fit's outputs removed before the first file, each
            file is listed as it is written, and the manifest is complete after the last.

    Raises:
        InvalidParameterError: ``out`` holds a file of :data:`OUTPUTS` that no earlier fit's
            manifest lists, or one changed since, or another command's outputs, or another
            process writes it (one line each); ``folder`` is not ``out``'s.
    """
    out = Path(out)
    if folder is None:
        with claim(out, COMMAND, {}, outputs=list(OUTPUTS), replace_same_command=True) as claimed:
            return write_report(result, log, out, validation, figures, folder=claimed)
    if Path(folder.out).resolve() != out.resolve():
        raise InvalidParameterError(f"write_report: folder= is {folder.out}'s claim, not out={out}'s")
    written: list[Path] = []

    def wrote(*paths: Path) -> None:
        written.extend(paths)
        folder.record(list(paths))  # listed at once: a rerun may replace it if this fit stops here

    folder.start()  # marked incomplete; the earlier fit's outputs go now
    record = parameters_record(result, validation)
    wrote(write_text_atomically(out / "parameters.json", json.dumps(record, indent=2) + "\n"))
    if result.xacro_arguments is not None:
        text = json.dumps(result.xacro_arguments, indent=2) + "\n"
        wrote(write_text_atomically(out / "xacro_arguments.json", text))
    urdf = identified_urdf(result)
    if urdf is not None:
        wrote(write_text_atomically(out / "robot.urdf", urdf))
    if figures:
        _figures(result, log, out, wrote)  # each listed once saved
    wrote(write_text_atomically(out / "report.md", _markdown(result, record, validation, figures)))
    folder.finish(written)
    return written


def _markdown(result: IdentificationResult, record: dict, validation: dict | None, figures: bool) -> str:
    r = record["rank"]
    lines = [
        f"# Identification of {record['robot']}",
        "",
        *(f"**{line}**\n" for line in record["warnings"]),
        *(f"{line}\n" for line in record["notes"]),
        f"{r['base_parameters']} base parameters of {r['standard_parameters']} standard ones "
        "(pivoted QR, rank "
        f"tolerance {r['rtol']:g} of |R_11|: smallest kept {r['smallest_kept']:.3g}, largest dropped "
        f"{r['largest_dropped']:.3g}); bodies held at their file's (zero) inertia: "
        f"{', '.join(record['fixed_bodies']) or 'none'}.",
        "",
        f"Fit: {result.samples} rows per joint after the parallel filter ({result.cutoff:g} Hz) "
        "and decimation; velocities "
        + ("from the log's qd" if result.velocities == "logged" else "from the positions")
        + (
            ""
            if result.velocity_lag is None
            else " (qd's lag behind the positions' derivative "
            + ", ".join(f"{x * 1e3:.3g} ms" for x in result.velocity_lag)
            + ")"
        )
        + "; "
        f"cond of the column-scaled base regressor {result.condition:.4g}; residual RMS "
        + ", ".join(f"{x:.3g}" for x in record["fit"]["residual_relative"])
        + " of the torque's RMS per joint; "
        + f"{result.timings.get('total', float('nan')):.2f} s.",
        "",
        "| base parameter | combination | WLS | std | OLS | consistent | nominal |",
        "|---|---|---|---|---|---|---|",
    ]

    def fmt(x):
        return "" if x is None else f"{x:.6g}"

    for row in record["base_parameters"]:
        lines.append(
            f"| {row['name']} | {row['combination']} | {fmt(row['wls'])} | {fmt(row['std'])} "
            f"| {fmt(row['ols'])} "
            f"| {fmt(row['consistent'])} | {fmt(row['nominal'])} |"
        )
    if record["dropped"]:
        lines += [
            "",
            f"Essential fit: {len(record['dropped'])} of {r['base_parameters']} base parameters set to 0 "
            "(|beta| / sigma < 3, in the order they went; parameters.json `dropped`): "
            + ", ".join(f"{d['name']} (t {fmt(d['t'])})" for d in record["dropped"])
            + ".",
        ]
    if record["friction"]:
        joints = record["joints"]
        lines += [
            "",
            "Friction and rotor inertia per joint: bounded least squares (fc, fs, fv, Ia >= 0: static >= "
            "Coulomb), the unconstrained WLS value in brackets (blank: lumped with other parameters):",
            "",
            "| | " + " | ".join(joints) + " |",
            "|---|" + "---|" * len(joints),
        ]
        for prefix, values in record["friction"].items():
            free = record["friction_unconstrained"].get(prefix, [None] * len(values))
            cells = [
                "" if v is None else f"{v:.6g} ({u:.6g})" if u is not None else f"{v:.6g}"
                for v, u in zip(values, free, strict=True)
            ]
            lines.append(f"| {prefix} | " + " | ".join(cells) + " |")
    if "consistent" in record:
        c = record["consistent"]
        lines += [
            "",
            f"Physically consistent estimate (log-Cholesky, every pseudo-inertia ⪰ 0: smallest eigenvalue "
            f"{min(c['min_pseudo_inertia_eigenvalue'], default=0.0):.3g}): distance to WLS "
            f"{c['distance_relative']:.3g} relative, {c['distance_mahalanobis']:.3g} in the WLS metric. "
            + consistent_status(result)
            + ".",
        ]
    if "lumped" in record:
        lines += ["", "The paper's lumped terms (eqs. 7-9) from the base parameters:", ""]
        lines += [f"- {k} = {v:.6g}" for k, v in record["lumped"].items()]
        lines += ["", "xacro arguments of the identified Delta: " + json.dumps(record["xacro_arguments"])]
    if validation is not None:
        lines += [
            "",
            "Validation on an unseen log, torque error relative to the torque's RMS per joint ("
            + validation_summary(validation).removeprefix("validation: ")
            + "):",
            "",
            "| | " + " | ".join(record["joints"]) + " |",
            "|---|" + "---|" * len(record["joints"]),
        ]
        away = validation["away_from_reversals"]
        for label, values in (
            ("RMS, every row", validation["rms_relative"]),
            ("max, every row", validation["max_relative"]),
            ("RMS, away from reversals", away["rms_relative"]),
            ("max, away from reversals", away["max_relative"]),
        ):
            lines.append(
                f"| {label} | " + " | ".join(fmt(_float(x) if x is not None else None) for x in values) + " |"
            )
    if figures:
        lines += [
            "",
            "![torque](torque.png)",
            "",
            "![residual](residual.png)",
            "",
            "![condition](condition.png)",
        ]
    return "\n".join(lines) + "\n"
