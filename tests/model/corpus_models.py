"""The corpus: every third-party closed-chain model in tests/data, as its authors ship it.

Each entry names the file (relative to tests/data), where it comes from (repository and commit;
the per-source README.md beside the files gives paths, blob hashes and licences), what kind of
mechanism it is, and the keyword arguments of ``dp.load_robot`` that the file genuinely cannot
express (none so far: see ``why`` where an entry has some). The files are unmodified copies;
``tests/model/test_corpus.py`` loads each one, and ``scripts/corpus_table.py`` runs each through
load, classification, validate and a short free fall and prints a status table.

Why no entry has keyword arguments: the files without motors (MuJoCo's, Pinocchio's and two of
Genesis' test models) need none by ``load_robot``'s own contract (a motorless MJCF file: its
passive joints are chosen), so a refusal of one is the loader's to fix, not the user's to work
around; Genesis' ``four_bar_linkage`` names two motors on a one-degree-of-freedom loop, which an
``actuated=`` would contradict, not complete; Gepetto's bipeds are loaded on a free flyer by
Gepetto's ``robot_options.py`` (``battobot_6d``, ``digit_like_2legs*``, ``disney_*``,
``true_talos_2_legs``), an option of the user's (``free_flyer=True``) that the fixed-base model
does not need; ``kangaroo_like_2leg`` ships no closures at all, which no keyword can supply.

Kinds: ``planar`` (planar linkage), ``spatial`` (spatial parallel mechanism), ``leg`` (a leg or a
pair of legs with closed knee/ankle linkages), ``humanoid``, ``gripper`` (an underactuated
linkage gripper), ``test`` (a physics engine's test model: free or hinged bodies tied by
``connect``/``weld`` equalities).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

__all__ = ["CORPUS", "DATA", "CorpusModel", "corpus_ids", "corpus_model"]

DATA = Path(__file__).resolve().parents[1] / "data"

GEPETTO = "Gepetto/example-parallel-robots@52e64b31c2ef122feffa571b78134d4529f9050a"
MUJOCO = "google-deepmind/mujoco@a7255075b003506ff5f34b512d88e02df12a73c6"
MENAGERIE = "google-deepmind/mujoco_menagerie@9e9185d772df5812346ae4668def8117b354bbae"
PINOCCHIO = "stack-of-tasks/pinocchio@c51d9234f9e34be97ed73bdb2772bd4a61469719"
GENESIS = "Genesis-Embodied-AI/Genesis@7bf5f6a7bf2946efc3a1e93667700011456078b5"
GENESIS_INDEX = "Genesis-Embodied-AI/Genesis@bd7655a3e2a035dcfe5df15fe9945dec30532a9a"


@dataclass(frozen=True)
class CorpusModel:
    """One model of the corpus.

    Attributes:
        id: a short unique name (``source/model``).
        path: the file ``dp.load_robot`` reads, relative to tests/data.
        source: ``owner/repo@commit`` it was copied from.
        licence: its licence (SPDX identifier).
        kind: ``planar``, ``spatial``, ``leg``, ``humanoid``, ``gripper`` or ``test``.
        kwargs: keyword arguments of ``dp.load_robot`` the file cannot express (empty: as shipped).
        why: why each keyword argument is needed (required where kwargs is not empty).
        notes: what the file is, in a line.
    """

    id: str
    path: str
    source: str
    licence: str
    kind: str
    notes: str
    kwargs: dict = field(default_factory=dict)
    why: str = ""

    @property
    def file(self) -> Path:
        return DATA / self.path


def _gepetto(name: str, kind: str, notes: str, urdf: str = "robot.urdf") -> CorpusModel:
    return CorpusModel(f"gepetto/{name}", f"gepetto/{name}/{urdf}", GEPETTO, "BSD-3-Clause", kind, notes)


CORPUS: tuple[CorpusModel, ...] = (
    # Gepetto's example-parallel-robots: URDF + robot.yaml (closed_loop frame pairs, name_mot).
    _gepetto("5bar_linkage", "planar", "planar five-bar, one 6D closure, 2 motors"),
    _gepetto("5bar_linkage_iso3d", "planar", "isostatic five-bar, one 3D closure, 2 motors"),
    _gepetto("5bar_linkage_iso6d", "planar", "isostatic five-bar, one 6D closure, 2 motors"),
    _gepetto("robot_delta", "spatial", "Delta (parallelogram rods), three 6D closures, 2 named motors"),
    _gepetto("battobot_6d", "leg", "BattoBot biped legs (Onshape export), six 6D knee/ankle closures"),
    _gepetto("cassie_like", "leg", "Cassie-like leg, two 6D closures, 5 motors"),
    _gepetto("digit_like", "leg", "Digit-like leg, three 6D closures, 6 motors"),
    _gepetto("digit_like_2legs", "leg", "Digit-like biped, six 6D closures"),
    _gepetto("digit_like_2legs_6D", "leg", "Digit-like biped (6D variant), six 6D closures"),
    _gepetto("digit_like_2legs_old", "leg", "Digit-like biped (older export), six 6D closures"),
    _gepetto("old/digit_like_2legs", "leg", "robots/old/digit_like_2legs: same URDF as digit_like_2legs_6D"),
    _gepetto("disney_like", "leg", "Disney-like leg (four-bar knee and ankle), three 6D closures"),
    _gepetto("disney_robot", "leg", "Disney-like biped, six 6D closures"),
    _gepetto("kangaroo_like", "leg", "Kangaroo-like leg, many 3D/6D closures (linear actuators)"),
    _gepetto(
        "kangaroo_like_2leg",
        "leg",
        "Kangaroo-like biped, URDF only: upstream ships no robot.yaml for it (no closures, no motors)",
    ),
    _gepetto("kangaroo_like_2legs", "leg", "Kangaroo-like biped, 3D and 6D closures"),
    _gepetto("talos_like", "leg", "TALOS-like leg, one 6D closure, 6 motors"),
    _gepetto(
        "true_talos_2_legs",
        "humanoid",
        "TALOS humanoid, two 3D ankle closures; upstream's URDF is talos_full_v2.urdf (no robot.urdf)",
        urdf="talos_full_v2.urdf",
    ),
    _gepetto("wl16_like", "leg", "WL-16-like leg (Stewart-like), five 6D closures, 6 motors"),
    # MuJoCo's engine test models (MJCF equality connect/weld, primitive geoms only).
    CorpusModel(
        "mujoco/jdotv_connect_2d",
        "mujoco/jdotv_connect_2d.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "world hinge pendulum whose tip a connect ties to a planar (2 slides + hinge) body; no motor",
    ),
    CorpusModel(
        "mujoco/jdotv_connect_3d",
        "mujoco/jdotv_connect_3d.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "ball-joint pendulum whose tip a connect ties to a free body; no motor",
    ),
    CorpusModel(
        "mujoco/jdotv_weld_3d",
        "mujoco/jdotv_weld_3d.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "ball-joint pendulum welded (torquescale 0.1) to a free body; no motor",
    ),
    CorpusModel(
        "mujoco/connect",
        "mujoco/connect.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "three free beams each held to the world by a connect (body, body pair, site pair); no motor",
    ),
    CorpusModel(
        "mujoco/weld",
        "mujoco/weld.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "five free beams welded to static bodies (torquescale, relpose, anchor, sites): mobility 0",
    ),
    CorpusModel(
        "mujoco/equality_site",
        "mujoco/equality_site.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "three free bodies held by a site connect, a weak weld and a weld; no motor",
    ),
    CorpusModel(
        "mujoco/island_efc",
        "mujoco/island_efc.xml",
        MUJOCO,
        "Apache-2.0",
        "test",
        "constraint-island test: a joint equality, two connects, a limit, friction loss, free bodies",
    ),
    # MuJoCo Menagerie (MJCF with meshes).
    CorpusModel(
        "menagerie/agility_cassie",
        "menagerie/agility_cassie/cassie.xml",
        MENAGERIE,
        "MIT",
        "leg",
        "Cassie biped on a free base: 4 connects (achilles and plantar rods), sprung shins, 10 motors",
    ),
    CorpusModel(
        "menagerie/robotiq_2f85",
        "menagerie/robotiq_2f85/2f85.xml",
        MENAGERIE,
        "BSD-2-Clause",
        "gripper",
        "Robotiq 2F-85: two four-bars (connects), a driver coupling, one tendon position servo",
    ),
    # Pinocchio's unit-test models.
    CorpusModel(
        "pinocchio/closed_chain",
        "pinocchio/closed_chain.xml",
        PINOCCHIO,
        "BSD-2-Clause",
        "leg",
        "Cassie (menagerie's, reduced: no meshes, no actuators) on a free base: 4 connects, springs",
    ),
    CorpusModel(
        "pinocchio/test_mjcf",
        "pinocchio/test_mjcf.xml",
        PINOCCHIO,
        "BSD-2-Clause",
        "test",
        "hinge-slide-ball chain with a weld and a connect between adjacent bodies; no motor",
    ),
    # Genesis' MJCF assets.
    CorpusModel(
        "genesis/four_bar_linkage",
        "genesis/four_bar_linkage.xml",
        GENESIS,
        "Apache-2.0",
        "planar",
        "four-bar (3 hinges, one connect), zero gravity, two motors on a one-dof loop",
    ),
    CorpusModel(
        "genesis/four_bar_linkage_weld",
        "genesis/four_bar_linkage_weld.xml",
        GENESIS,
        "Apache-2.0",
        "planar",
        "the same four-bar, tilted, closed by a weld instead of a connect; zero gravity; no motor",
    ),
    CorpusModel(
        "genesis/connect_loop",
        "genesis/connect_loop.xml",
        GENESIS_INDEX,
        "Apache-2.0",
        "planar",
        "two coaxial hinged arms tied by a connect (one dof, 3 equations of rank 1); no motor",
    ),
)


def corpus_ids() -> list[str]:
    return [m.id for m in CORPUS]


def corpus_model(model_id: str) -> CorpusModel:
    for model in CORPUS:
        if model.id == model_id:
            return model
    raise KeyError(f"no corpus model {model_id!r}; known: {', '.join(corpus_ids())}")
