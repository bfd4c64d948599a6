"""Headless meshcat export (delta_pin.viz.meshcat_export): page structure, a real browser, bad input.

The browser tests render the exported page in headless Debian chromium (software WebGL through
SwiftShader) and skip only when no ``chromium`` executable can be found.
"""

import base64
import json
import os
import re
import shutil
import subprocess
import time
import uuid
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

import delta_pin as dp
from delta_pin.control import Controller, ControlOutput
from delta_pin.errors import DeltaPinError, InvalidParameterError
from delta_pin.sim.run import Run
from delta_pin.sim.runner import simulate
from delta_pin.viz.meshcat_export import (
    DEFAULT_PATH_COLORS,
    EmptyRunError,
    RobotMismatchError,
    RunFileNotFoundError,
    VisualizationError,
    export_html,
    read_scene_commands,
    view_live,
)
from tests.viz.browser import run_browser

meshcat = pytest.importorskip("meshcat")

RUN_SECONDS = 15.0  # [s]
FPS = 30.0  # [frames/s]
# Stated bound on the page of a 15 s run at 30 frames/s: measured 1.29 MB (0.85 MB of it is
# meshcat's inlined JS bundle, ~0.3 MB the 451-frame animation, ~0.13 MB the two 4000-point paths).
MAX_PAGE_BYTES = 2_000_000

CHROMIUM = shutil.which("chromium")
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium is not installed (Debian: apt-get install -y chromium)"
)
WINDOW = (800, 600)  # [px] width, height of the headless window


class PDGravity(Controller):
    """Joint PD around the reference plus the gravity torque at the path's centre (cheap, tracks ~mm)."""

    name = "pd_gravity"

    def __init__(self, robot):
        self.G0 = robot.analytic_dynamics(robot.inverse_kinematics([0.0, 0.0, -0.4]), np.zeros(3)).G

    def evaluate(self, t, alpha, alpha_dot, reference, state):
        return ControlOutput(
            self.G0 + 60.0 * (reference.alpha - alpha) + 3.0 * (reference.alpha_dot - alpha_dot)
        )


@pytest.fixture(scope="module")
def run15(robot):
    """15 s along the paper's path II (a 0.1 m circle per 2 s). dt = 2 ms keeps it ~2 s to simulate;
    the page is the same size as at 1 kHz, since each path line keeps at most 4000 points."""
    return simulate(robot, PDGravity(robot), dp.PathII(), plant="analytic", t_end=RUN_SECONDS, dt=2e-3)


@pytest.fixture(scope="module")
def page15(run15, tmp_path_factory) -> Path:
    return export_html(run15, tmp_path_factory.mktemp("html") / "run15.html", fps=FPS)


@pytest.fixture(scope="module")
def short_run(robot):
    a0 = robot.inverse_kinematics([0.0, 0.0, -0.35])
    G0 = robot.analytic_dynamics(a0, np.zeros(3)).G
    return simulate(
        robot,
        lambda t, a, ad: G0 + 2 * (a0 - a) - 0.1 * ad + 0.05 * np.sin(3 * t),
        alpha0=a0,
        plant="analytic",
        t_end=0.2,
    )


def commands_of(page: Path) -> list[dict]:
    return read_scene_commands(page.read_text(encoding="utf-8"))


def animation_of(commands: list[dict]) -> dict[str, dict]:
    """Animated clips by node path."""
    (command,) = [c for c in commands if c["type"] == "set_animation"]
    return {item["path"]: item["clip"] for item in command["animations"]}


def track(clip: dict, name: str) -> tuple[np.ndarray, np.ndarray]:
    (found,) = [t for t in clip["tracks"] if t["name"] == name]
    width = 3 if name == ".position" else 4
    values = np.asarray(found["values"], dtype=float).reshape(-1, width)
    return np.asarray(found["times"], dtype=float), values


# ----------------------------------------------------------------------------------- structure
class _Links(HTMLParser):
    """Every URL-valued attribute of the page's elements (script text is not parsed as tags)."""

    def __init__(self):
        super().__init__()
        self.urls = []
        self.tags = []

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.urls += [
            (tag, name, value) for name, value in attrs if name in ("src", "href", "data", "action")
        ]


def test_page_is_standalone_and_small(page15, run15):
    text = page15.read_text(encoding="utf-8")
    size = page15.stat().st_size
    assert size < MAX_PAGE_BYTES, f"{size} bytes for a {RUN_SECONDS} s run"
    assert text.lstrip().startswith("<!DOCTYPE html>")
    # meshcat's viewer is inlined, not loaded
    bundle = Path(meshcat.viewer_assets_path()) / "dist" / "main.min.js"
    assert bundle.read_text(encoding="utf-8") in text
    links = _Links()
    links.feed(text)
    # the bundle, the scene (JSON), the loader and meshcat's empty "embedded-json"
    assert links.tags.count("script") == 4
    assert links.urls == [], f"the page links to {links.urls}"
    # the scene script of our own (outside the bundle) fetches nothing
    own = text[text.index('<script id="delta-pin-scene"') :]
    assert not re.search(r"fetch\(|XMLHttpRequest|WebSocket|import\s*\(|https?://|wss?://", own)


def test_scene_draws_urdf_visuals_paths_and_real_time_animation(page15, run15, robot):
    import pinocchio as pin

    commands = commands_of(page15)
    objects = {c["path"]: c["object"] for c in commands if c["type"] == "set_object"}
    # every visual of the URDF, read through Pinocchio's geometry model, is drawn once
    geometry_model = pin.buildGeomFromUrdfString(robot.pinocchio.model, robot.urdf, pin.GeometryType.VISUAL)
    names = [g.name for g in geometry_model.geometryObjects]
    assert sorted(p.split("/")[-2] for p in objects if "/robot/" in p) == sorted(names)
    forearm = objects["/meshcat/delta_pin/robot/forearm_1_0/shape"]
    assert forearm["geometries"][0]["type"] == "CylinderGeometry"
    assert forearm["geometries"][0]["height"] == pytest.approx(robot.params.l_b, rel=1e-6)
    platform_color = objects["/meshcat/delta_pin/robot/platform_0/shape"]["materials"][0]["color"]
    assert platform_color == int(0.93 * 255 + 0.5) << 16 | int(0.50 * 255 + 0.5) << 8 | int(0.13 * 255 + 0.5)

    # two path lines, of two colours, through the run's samples
    desired = objects["/meshcat/delta_pin/paths/desired"]
    actual = objects["/meshcat/delta_pin/paths/actual"]
    assert desired["object"]["type"] == actual["object"]["type"] == "Line"
    colors = desired["materials"][0]["color"], actual["materials"][0]["color"]
    assert colors == DEFAULT_PATH_COLORS and colors[0] != colors[1]
    points = np.asarray(actual["geometries"][0]["data"]["attributes"]["position"]["array"]).reshape(-1, 3)
    assert len(points) == 4000
    np.testing.assert_allclose(points[0], run15.xyz[0], atol=1e-6)
    np.testing.assert_allclose(points[-1], run15.xyz[-1], atol=1e-6)

    # real time: keys at frames 0..450, clip at FPS frames/s -> the clip lasts the run's 15 s
    clips = animation_of(commands)
    platform = clips["/meshcat/delta_pin/robot/platform_0"]
    assert platform["fps"] == FPS
    times, positions = track(platform, ".position")
    np.testing.assert_array_equal(times, np.arange(int(RUN_SECONDS * FPS) + 1))
    assert times[-1] / platform["fps"] == pytest.approx(run15.t[-1] - run15.t[0])
    # the platform drawn from q(alpha) (closure solve) is where the plant put it (independent route)
    frame_times = times / FPS
    expected = np.column_stack([np.interp(frame_times, run15.t, run15.xyz[:, j]) for j in range(3)])
    np.testing.assert_allclose(positions, expected, atol=2e-6)
    # the base does not move; every other visual is animated
    assert "/meshcat/delta_pin/robot/base_link_0" not in clips
    assert len(clips) == len(names) - 1


def test_desired_ghost_follows_the_reference(run15, tmp_path):
    page = export_html(
        run15, tmp_path / "ghost.html", show_desired_ghost=True, path_colors=("#00ff00", 0xFF00FF)
    )
    commands = commands_of(page)
    ghost = {
        c["path"]: c["object"]
        for c in commands
        if c["type"] == "set_object" and "/desired_pose/" in c["path"]
    }
    assert len(ghost) == 13  # every moving visual, not the base
    for obj in ghost.values():
        material = obj["materials"][0]
        assert material["transparent"] and 0.0 < material["opacity"] < 1.0
        assert material["color"] == 0x00FF00
    times, positions = track(
        animation_of(commands)["/meshcat/delta_pin/desired_pose/platform_0"], ".position"
    )
    expected = np.column_stack([np.interp(times / FPS, run15.t, run15.xyz_d[:, j]) for j in range(3)])
    np.testing.assert_allclose(positions, expected, atol=2e-6)


def test_export_from_a_run_file_writes_atomically(short_run, tmp_path):
    run_file = short_run.save(tmp_path / "run.npz")
    target = tmp_path / "nested" / "dir" / "run.html"
    assert export_html(run_file, target) == target
    first = target.read_text(encoding="utf-8")
    export_html(str(run_file), target, fps=10.0)  # replaces the file
    assert target.read_text(encoding="utf-8") != first
    assert sorted(p.name for p in target.parent.iterdir()) == ["run.html"]  # no temporary file left
    # 0.2 s at 10 frames/s: keys at frames 0, 1, 2, clip fps 10
    clip = next(iter(animation_of(commands_of(target)).values()))
    assert clip["fps"] == 10.0
    np.testing.assert_allclose(track(clip, ".quaternion")[0], [0.0, 1.0, 2.0])


def test_fps_not_dividing_the_run_keeps_its_end(short_run, tmp_path):
    page = export_html(short_run, tmp_path / "run.html", fps=7.0)  # 0.2 s = 1.4 frames
    clip = next(iter(animation_of(commands_of(page)).values()))
    times, _ = track(clip, ".position")
    np.testing.assert_allclose(times / clip["fps"], [0.0, 1 / 7.0, 0.2], atol=1e-7)


def test_run_of_another_robot_draws_that_robot(tmp_path):
    other = dp.load_delta(l_a=0.25, l_b=0.5)
    a0 = other.inverse_kinematics([0.0, 0.0, -0.45])

    def hold(t, a, ad):
        return other.analytic_dynamics(a, ad).G

    run = simulate(other, hold, alpha0=a0, plant="analytic", t_end=0.05)
    page = export_html(run, tmp_path / "other.html")  # robot=None: rebuilt from the run's URDF
    objects = {c["path"]: c["object"] for c in commands_of(page) if c["type"] == "set_object"}
    arm = objects["/meshcat/delta_pin/robot/upper_arm_2_0/shape"]["geometries"][0]
    assert arm["height"] == pytest.approx(0.25)


def first_samples(run: Run, count: int) -> Run:
    arrays = ("t", "alpha", "alpha_dot", "alpha_d", "alpha_dot_d", "xyz", "xyz_d", "tau", "closure_residual")
    return Run(**{name: getattr(run, name)[:count] for name in arrays}, metadata=run.metadata)


def test_single_sample_run_is_a_still_scene(short_run, tmp_path):
    run = first_samples(short_run, 1)
    commands = commands_of(export_html(run, tmp_path / "still.html"))
    assert not [c for c in commands if c["type"] == "set_animation"]
    assert any(c["type"] == "set_transform" and c["path"].endswith("/robot/platform_0") for c in commands)


# ----------------------------------------------------------------------------------- bad input
def test_run_from_another_robot_is_refused(short_run, tmp_path):
    other = dp.load_delta(l_a=0.25)
    with pytest.raises(RobotMismatchError, match=r"l_a = 0\.2 \(run\) vs 0\.25 \(robot\)") as info:
        export_html(short_run, tmp_path / "x.html", robot=other)
    assert isinstance(info.value, DeltaPinError)
    assert not (tmp_path / "x.html").exists()


def test_run_with_the_same_robot_is_accepted(short_run, robot, tmp_path):
    assert export_html(short_run, tmp_path / "ok.html", robot=robot).is_file()


def test_missing_run_file(tmp_path):
    missing = tmp_path / "no_such_run.npz"
    with pytest.raises(RunFileNotFoundError, match=r"no_such_run\.npz.*does not exist") as info:
        export_html(missing, tmp_path / "x.html")
    assert isinstance(info.value, DeltaPinError) and isinstance(info.value, FileNotFoundError)


def test_file_that_is_not_a_run(tmp_path):
    bogus = tmp_path / "notes.npz"
    bogus.write_text("not a run")
    with pytest.raises(VisualizationError, match=r"notes\.npz.*not a run file"):
        export_html(bogus, tmp_path / "x.html")


def test_empty_run(short_run, tmp_path):
    empty = first_samples(short_run, 0)
    with pytest.raises(EmptyRunError, match="no samples"):
        export_html(empty, tmp_path / "x.html")
    empty.save(tmp_path / "empty.npz")
    with pytest.raises(EmptyRunError):
        export_html(tmp_path / "empty.npz", tmp_path / "x.html")


def test_run_without_urdf_needs_a_robot(short_run, robot, tmp_path):
    bare = Run(**{**short_run.__dict__, "metadata": {}})
    with pytest.raises(VisualizationError, match="no URDF"):
        export_html(bare, tmp_path / "x.html")
    assert export_html(bare, tmp_path / "x.html", robot=robot).is_file()


@pytest.mark.parametrize(
    "kwargs", [{"fps": 0.0}, {"fps": float("nan")}, {"path_colors": ("red", 0)}, {"path_colors": (1,)}]
)
def test_bad_options(short_run, tmp_path, kwargs):
    with pytest.raises(InvalidParameterError):
        export_html(short_run, tmp_path / "x.html", **kwargs)


def test_non_finite_angles_name_the_time(short_run, tmp_path):
    alpha = short_run.alpha.copy()
    alpha[50, 1] = np.nan
    run = Run(**{**short_run.__dict__, "alpha": alpha})
    with pytest.raises(dp.NonFiniteError, match=r"t=0\.05 s"):
        export_html(run, tmp_path / "x.html")


def live_scene_commands(run, robot=None) -> list[dict]:
    """The commands a real local meshcat server holds after :func:`view_live` drew ``run``
    (skips where no local server can start: ports, sandbox)."""
    zmq = pytest.importorskip("zmq")
    import umsgpack

    try:
        vis = view_live(run, robot)
    except (OSError, RuntimeError, zmq.ZMQError) as exc:
        pytest.skip(f"could not start a local meshcat server: {exc}")
    try:
        live_page = vis.static_html()
    finally:
        vis.window.server_proc.kill()
        vis.window.server_proc.wait()
    return [
        umsgpack.unpackb(base64.b64decode(data))
        for data in re.findall(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)", live_page)
    ]


def scene_key(command: dict) -> tuple:
    """What identifies a scene command: its type, path and property."""
    return command["type"], command["path"], command.get("property")


# -------------------------------------------------------------------------------- real browser
BROWSER_TIMEOUT_FLOOR = 300.0  # [s] the least wall time a browser run is given (a CI run beside a
# C++ build took over 120 s for the mesh page while a blank page still rendered fast)
BROWSER_TIMEOUT_SCALE = 40.0  # x the time this machine takes to render a blank page, now
BROWSER_TIMEOUT_CEILING = 900.0  # [s] beyond this the browser is hung, not slow


def _chromium_command(tmp_path: Path, url: str, *options: str, budget_ms: int) -> list[str]:
    profile = tmp_path / f"profile-{uuid.uuid4().hex[:8]}"
    return [
        CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
        "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
        f"--user-data-dir={profile}", f"--window-size={WINDOW[0]},{WINDOW[1]}",
        f"--virtual-time-budget={budget_ms}", *options, url,
    ]  # fmt: skip


def browser_timeout(tmp_path: Path) -> float:
    """Wall time [s] a browser run gets on this machine as loaded as it is now: a blank page's
    render timed just before, scaled (a busy 2-core machine took over 120 s for a mesh page that
    an idle one renders in ~5 s), within [floor, ceiling]."""
    start = time.perf_counter()
    run_browser(
        _chromium_command(tmp_path, "about:blank", f"--screenshot={tmp_path / 'blank.png'}", budget_ms=100),
        BROWSER_TIMEOUT_CEILING, retries=0,
    )  # fmt: skip
    blank = time.perf_counter() - start
    return min(max(BROWSER_TIMEOUT_FLOOR, BROWSER_TIMEOUT_SCALE * blank), BROWSER_TIMEOUT_CEILING)


def chromium(tmp_path: Path, url: str, *options: str, budget_ms: int) -> subprocess.CompletedProcess:
    """Run headless chromium once (its own fresh profile) on ``url`` for ``budget_ms`` of virtual
    time, with the wall-time limit of :func:`browser_timeout`."""
    command = _chromium_command(tmp_path, url, *options, budget_ms=budget_ms)
    timeout = browser_timeout(tmp_path)
    result = run_browser(command, timeout)
    assert result.returncode == 0, result.stderr[-2000:]
    return result


def screenshot(tmp_path: Path, page: Path, budget_ms: int, *options: str) -> np.ndarray:
    from PIL import Image

    png = tmp_path / f"shot-{budget_ms}.png"
    chromium(tmp_path, page.as_uri(), f"--screenshot={png}", *options, budget_ms=budget_ms)
    return np.asarray(Image.open(png).convert("RGB")).astype(int)


def page_requests(netlog: Path) -> list[str]:
    """URLs the PAGE asked the network for (chromium's own requests have initiator 'not an origin')."""
    log = json.loads(netlog.read_text())
    start_job = log["constants"]["logEventTypes"]["URL_REQUEST_START_JOB"]
    return [
        event["params"]["url"]
        for event in log["events"]
        if event["type"] == start_job
        and "url" in event.get("params", {})
        and event["params"].get("initiator") != "not an origin"
    ]


def robot_statistics(rgb: np.ndarray) -> dict[str, float]:
    """meshcat's background (a sky-blue to navy gradient) and the blue upper arms are blue-dominant;
    the grey base, forearms and elbows and the orange platform are not."""
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    not_blue = (b - r) < 40
    orange = (r > 180) & (g > 80) & (g < 180) & (b < 100)
    return {
        # top-left sky, away from the robot and from meshcat's "Open Controls" bar (top right)
        "sky": float(not_blue[40:120, 0:150].mean()),
        # where the camera framing puts the robot: the base near the top third, the platform below
        "robot": float(not_blue[150:580, 50:750].mean()),
        "platform": int(orange.sum()),
    }


@needs_chromium
def test_browser_renders_the_robot_offline_and_animates(page15, tmp_path):
    netlog = tmp_path / "netlog.json"
    early = screenshot(tmp_path, page15, 500, f"--log-net-log={netlog}")
    late = screenshot(tmp_path, page15, 3000)
    assert early.shape == late.shape == (WINDOW[1], WINDOW[0], 3)
    for rgb in (early, late):
        stats = robot_statistics(rgb)
        # measured: sky 0.0, robot 0.155-0.168, platform 8000-10200 px
        assert stats["sky"] < 0.02, stats  # the background is drawn: WebGL works
        assert 0.06 < stats["robot"] < 0.6, stats  # grey links fill a good part of the view
        assert stats["platform"] > 2000, stats  # the orange platform is in view
    # the animation plays: at 3 s of virtual time the robot is elsewhere (measured: 11% of pixels)
    changed = (np.abs(early - late).sum(axis=-1) > 60).mean()
    assert changed > 0.02, changed
    # and the page fetched nothing from the network while loading and playing
    assert page_requests(netlog) == []


@needs_chromium
def test_netlog_check_sees_page_requests(tmp_path):
    """The network check above is meaningful: a page that does fetch is caught."""
    page = tmp_path / "fetching.html"
    page.write_text(
        '<!DOCTYPE html><html><body><img src="http://example.invalid/a.png">'
        '<script>fetch("https://example.invalid/b").catch(function () {});</script></body></html>'
    )
    netlog = tmp_path / "netlog.json"
    chromium(tmp_path, page.as_uri(), "--dump-dom", f"--log-net-log={netlog}", budget_ms=500)
    assert sorted(page_requests(netlog)) == ["http://example.invalid/a.png", "https://example.invalid/b"]


PLAYBACK_PROBE = """<script>
(function () {
    var animator = viewer.animator, update = animator.update.bind(animator), first = null;
    animator.update = function () {
        update();
        if (!animator.playing) { return; }
        var sample = [performance.now() / 1000.0, animator.time];
        if (first === null) { first = sample; }
        document.body.setAttribute("data-playback",
            JSON.stringify({first: first, last: sample, duration: animator.duration}));
    };
})();
</script>"""


@needs_chromium
def test_browser_plays_at_real_time_speed(page15, run15, tmp_path):
    """A copy of the page with a probe that records the animation time against the page clock."""
    text = page15.read_text(encoding="utf-8")
    end = text.rindex("</body>")
    probe = tmp_path / "probe.html"
    probe.write_text(text[:end] + PLAYBACK_PROBE + text[end:], encoding="utf-8")
    # 8 s of virtual time: on a loaded 2-core machine loading the 1.3 MB page took most of a 3 s
    # budget once (0.41 s of playback left)
    dom = chromium(tmp_path, probe.as_uri(), "--dump-dom", budget_ms=8000).stdout
    match = re.search(r'data-playback="([^"]*)"', dom)
    assert match, "the animation did not play"
    playback = json.loads(match.group(1).replace("&quot;", '"'))
    assert playback["duration"] == pytest.approx(run15.t[-1] - run15.t[0], abs=1e-3)
    (clock0, time0), (clock1, time1) = playback["first"], playback["last"]
    assert clock1 - clock0 > 0.5, playback
    # 1 s of page clock plays 1 s of run (measured: slope 1.0001)
    assert (time1 - time0) / (clock1 - clock0) == pytest.approx(1.0, abs=0.02), playback


# ---------------------------------------------------------------------------------- live viewer
def test_live_viewer_smoke(short_run, tmp_path):
    """view_live draws, through a real local meshcat server, the same scene the export records."""
    if os.environ.get("DELTA_PIN_SKIP_LIVE_VIEWER"):
        pytest.skip("DELTA_PIN_SKIP_LIVE_VIEWER is set")
    live = live_scene_commands(short_run)
    recorded = commands_of(export_html(short_run, tmp_path / "run.html"))
    assert sorted(map(scene_key, live)) == sorted(map(scene_key, recorded))


# ---------------------------------------------------------------------------------- mesh visuals
MESH_URDF = dp.model.description.default_xacro_path().parent / "delta_mesh.urdf"


@pytest.fixture(scope="module")
def mesh_robot():
    return dp.load_delta(MESH_URDF)  # meshes/base.stl ... relative to the URDF's folder


@pytest.fixture(scope="module")
def mesh_page(mesh_robot, tmp_path_factory) -> Path:
    """2 s of path II on the mesh Delta, saved and exported from the run FILE (its URDF's folder
    travels in the run's metadata, so the relative mesh filenames still resolve)."""
    run = simulate(mesh_robot, PDGravity(mesh_robot), dp.PathII(), plant="analytic", t_end=2.0, dt=2e-3)
    folder = tmp_path_factory.mktemp("mesh")
    return export_html(run.save(folder / "run.npz"), folder / "mesh.html")


def test_export_draws_the_mesh_visuals(mesh_page, mesh_robot, page15):
    import trimesh

    commands = commands_of(mesh_page)
    objects = {c["path"]: c["object"] for c in commands if c["type"] == "set_object"}
    transforms = {c["path"]: c["matrix"] for c in commands if c["type"] == "set_transform"}
    shapes = {
        "base_link_0": "base.stl", "upper_arm_2_0": "upper_arm.obj", "forearm_3_0": "forearm.stl",
        "platform_0": "platform.dae",
    }  # fmt: skip
    for name, filename in shapes.items():
        geometry = objects[f"/meshcat/delta_pin/robot/{name}/shape"]["geometries"][0]
        assert geometry["type"] == "BufferGeometry"
        # the triangles of the file, vertex by vertex (float32), with a unit normal each
        mesh = trimesh.load(MESH_URDF.parent / "meshes" / filename, force="mesh")
        positions = np.asarray(geometry["data"]["attributes"]["position"]["array"]).reshape(-1, 3)
        np.testing.assert_allclose(positions, mesh.vertices[mesh.faces].reshape(-1, 3), atol=1e-6)
        normals = np.asarray(geometry["data"]["attributes"]["normal"]["array"]).reshape(-1, 3)
        np.testing.assert_allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-6)
    # the URDF's scale is the shape's transform: the forearm's unit cylinder is l_b long
    matrix = np.asarray(transforms["/meshcat/delta_pin/robot/forearm_3_0/shape"]).reshape(4, 4).T
    p = mesh_robot.params
    np.testing.assert_allclose(np.diag(matrix)[:3], [0.02 * p.l_b, 0.02 * p.l_b, p.l_b], rtol=1e-6)
    # primitives of the same URDF stay primitives (the elbow spheres, the arm hubs)
    elbow = objects["/meshcat/delta_pin/robot/forearm_3_1/shape"]["geometries"][0]
    assert elbow["type"] == "SphereGeometry"
    # the same visuals, in the same places, as the primitive Delta's page
    primitive = {
        c["path"] for c in commands_of(page15) if c["type"] == "set_object" and "/robot/" in c["path"]
    }
    assert {path for path in objects if "/robot/" in path} == primitive


def test_export_of_a_mesh_run_whose_mesh_is_gone_names_the_file(mesh_robot, tmp_path):
    folder = tmp_path / "robot"
    (folder / "meshes").mkdir(parents=True)
    for mesh in (MESH_URDF.parent / "meshes").iterdir():
        (folder / "meshes" / mesh.name).write_bytes(mesh.read_bytes())
    (folder / "delta.urdf").write_text(MESH_URDF.read_text())
    moved = dp.load_delta(folder / "delta.urdf")
    run = simulate(moved, PDGravity(moved), dp.PathII(), plant="analytic", t_end=0.01)
    (folder / "meshes" / "platform.dae").unlink()
    with pytest.raises(
        dp.MeshFileError,
        match=r"mesh 'meshes/platform\.dae' \(visual 0 of link 'platform'\): "
        r"file '.*platform\.dae' does not exist",
    ):
        export_html(run, tmp_path / "x.html")
    assert not (tmp_path / "x.html").exists()


@needs_chromium
def test_browser_renders_the_mesh_robot(mesh_page, tmp_path):
    rgb = screenshot(tmp_path, mesh_page, 1500)
    stats = robot_statistics(rgb)
    # measured: sky 0.0, robot ~0.16, platform (the orange DAE hexagon) ~9000 px
    assert stats["sky"] < 0.02, stats
    assert 0.06 < stats["robot"] < 0.6, stats
    assert stats["platform"] > 2000, stats
