"""The fixed-point network (tools/hpddo/model/quant.py, lib/hpddo_core/src/hpddo/mlp_q.h): its
accuracy cost against the float model, its overflow bounds, and its committed files."""
import numpy as np
import pytest

from conftest import ROOT
from hpddo.logs import dataset
from hpddo.model import export, quant

MODEL = ROOT / "models" / "default"
DATA = [ROOT / "data" / "default" / f"{n}.csv" for n in ("load", "long", "sweep")]
VALIDATION = [ROOT / "data" / "validation" / f"{n}.csv" for n in ("unseen", "hot")]
BUDGET_RPM = 0.05  # issue 14: RMS of fixed minus float estimates, at most


@pytest.fixture(scope="module")
def default():
    model = export.read_model_header((MODEL / "model_default.h").read_text())
    return model, quant.quantise(model)


def test_rounding_is_half_away_from_zero():
    assert [quant.round_half_away(v) for v in (0.5, 1.5, 2.5, -0.5, -2.5, 2.4999, -2.5001)] == [1, 2, 3, -1, -3, 2, -3]


def test_int8_hidden_weights_are_rejected_for_cause(default):
    """The hidden layer is int16 because int8 there costs more than the budget (measured)."""
    model, _ = default
    q8 = quant.quantise(model, "int8")
    acc = quant.accuracy(model, q8, dataset.load_recordings(DATA), "test")
    assert quant.DEFAULT_HIDDEN_TYPE == "int16"
    assert acc["all"]["rms_diff_rpm"] > BUDGET_RPM, acc


# The int8 model (issue 24): layer 0 and the hidden layer int8, the shifts from the envelope,
# the weights rounded for the training rows (quant.quantise's calibration).
@pytest.fixture(scope="module")
def default_int8(default):
    from hpddo.model import train
    model, _ = default
    recs = dataset.load_recordings(DATA)
    return model, export.quantise_int8(model, train.training_rows(recs, model.physics)[0])


# Both integer models (int16 layer 0: model_default_q.h; int8: model_default_q8.h): the
# committed header is the quantisation of the committed float model, and costs at most the
# budget against it.
VARIANTS = {"int16": ("model_default_q.h", "typedef hpddo::MlpQ<5, 16, 8, int16_t, "),
            "int8": ("model_default_q8.h", "typedef hpddo::MlpQ<5, 16, 8, int8_t, ")}


@pytest.fixture(params=list(VARIANTS))
def integer_model(request, default, default_int8):
    return (request.param, *(default if request.param == "int16" else default_int8))


def test_committed_integer_header_is_the_quantisation_of_the_committed_float_model(integer_model):
    name, model, q = integer_model
    header, typedef = VARIANTS[name]
    text = (MODEL / header).read_text()
    assert f"kChecksum = 0x{export.model_checksum_q(model, q):08x}u" in text
    assert typedef in text
    if name == "int8":
        assert ", int8_t> Net;" in text


@pytest.mark.parametrize("paths,part", [(DATA, "test"), (VALIDATION, "all")], ids=["default-test", "validation"])
def test_integer_accuracy_cost_against_the_float_model_is_within_budget(integer_model, paths, part):
    _, model, q = integer_model
    acc = quant.accuracy(model, q, dataset.load_recordings(paths), part)
    assert acc["all"]["rms_diff_rpm"] <= BUDGET_RPM, acc
    assert abs(acc["all"]["rmse_fixed_rpm"] - acc["all"]["rmse_float_rpm"]) <= BUDGET_RPM, acc


def test_int8_rounded_to_nearest_is_over_budget_for_cause(default):
    """Why the int8 weights are rounded for the training rows: to nearest, they cost more than
    the budget (measured on every run)."""
    model, _ = default
    q8 = export.quantise_int8(model)
    acc = quant.accuracy(model, q8, dataset.load_recordings(DATA), "test")
    assert acc["all"]["rms_diff_rpm"] > BUDGET_RPM, acc


def test_no_accumulator_overflows_for_any_input(integer_model):
    """forward_int asserts every sum within int32; inputs at the int16 extremes and random."""
    _, _, q = integer_model
    rng = np.random.default_rng(14)
    big = np.float32(3e38)
    for x in [np.full(5, big), np.full(5, -big), np.array([big, -big, big, -big, big], np.float32),
              *rng.uniform(-1e6, 1e6, (200, 5)).astype(np.float32)]:
        quant.forward_int(q, x)