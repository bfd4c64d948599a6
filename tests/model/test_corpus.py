"""Every third-party model of the corpus (tests/model/corpus_models.py), as shipped: it loads, or
``dp.load_robot`` refuses it with a delta-pin error of one line -- never an uncaught exception of
another kind, never a message a person has to scroll.

What each model then does (classification, validate, a free fall) is tabulated by
``scripts/corpus_table.py``; the outcomes are not asserted here yet.
"""

from __future__ import annotations

import warnings

import pytest

import delta_pin as dp
from delta_pin.errors import DeltaPinError
from tests.model.corpus_models import CORPUS, CorpusModel

MJCF_NEEDS_MUJOCO = "MuJoCo compiles MJCF files"


@pytest.mark.parametrize("model", CORPUS, ids=[m.id for m in CORPUS])
def test_a_corpus_model_loads_or_is_refused_in_one_line(model: CorpusModel):
    assert model.file.is_file(), f"{model.path} is missing from tests/data"
    if model.file.suffix == ".xml":
        pytest.importorskip("mujoco", reason=MJCF_NEEDS_MUJOCO)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the warnings a file earns are the table's business
        try:
            robot = dp.load_robot(model.file, **model.kwargs)
        except DeltaPinError as exc:
            message = str(exc)
            assert message.strip(), f"{type(exc).__name__} without a message"
            assert "\n" not in message.strip(), f"{type(exc).__name__} over several lines:\n{message}"
            return
    assert robot.model.nv > 0


def test_the_manifest_is_consistent():
    """Unique ids, known kinds, and a reason for every keyword argument."""
    ids = [m.id for m in CORPUS]
    assert len(ids) == len(set(ids))
    for model in CORPUS:
        assert model.kind in {"planar", "spatial", "leg", "humanoid", "gripper", "test"}, model.id
        assert not model.kwargs or model.why, f"{model.id}: kwargs without a reason"
        assert "@" in model.source and len(model.source.split("@")[1]) == 40, model.id
