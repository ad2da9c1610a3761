"""Smoke tests of `experiments.real_arm_actions` on small folders laid out like UE-ADL, written here
(simulated joint angles and Nexus marker files): a leave-one-person-out run writes the study's
metrics, report and figures; `--train/--test` folders make one fold; settings are chosen without
the held-out person; an absent folder is a clean skip."""
import json

import numpy as np
import pytest

pytestmark = pytest.mark.filterwarnings("ignore:h5py not installed:UserWarning")  # tslearn's import
pytest.importorskip("hmmlearn")
pytest.importorskip("tslearn")

from experiments.real_arm_actions import evaluation as ev  # noqa: E402
from experiments.real_arm_actions import methods as mt  # noqa: E402
from experiments.real_arm_actions import main  # noqa: E402
from experiments.real_arm_actions.config import Config  # noqa: E402
from experiments.real_arm_actions.data import load_dataset  # noqa: E402
from experiments.real_arm_actions.stages import available_kinds, folds_for  # noqa: E402
from tests.mocap_files import write_ue_adl_folder  # noqa: E402

TINY = ["--preset", "quick", "--n-frames", "20", "--grid-states", "4", "--n-iter", "3", "--recognition-steps", "2"]
KEYS = ("accuracy_edhmm", "accuracy_hmm", "accuracy_hmmlearn", "accuracy_dtw", "runtime_s")


def test_leave_one_person_out_on_angles_and_markers(tmp_path):
    root = write_ue_adl_folder(tmp_path / "adl", ["P01", "P02"], markers=True)
    written = main(TINY + ["--data", str(root), "--out", str(tmp_path / "run")])
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics == written and metrics["skipped"] is False
    for prefix in ("", "markers_"):
        for key in KEYS[:4]:
            assert 0.0 <= metrics[prefix + key] <= 1.0
        assert {f"{prefix}per_person_accuracy_edhmm_{p}" for p in ("P01", "P02")} <= set(metrics)
        assert np.sum(metrics[f"{prefix}confusion_dtw"]) == metrics[f"{prefix}n_test_sequences"] == 32
        assert 0.0 <= metrics[f"{prefix}side_accuracy_phmm"] <= 1.0
        assert 0.0 <= metrics[f"{prefix}side_accuracy_regression"] <= 1.0
        assert metrics[f"{prefix}side_error_regression"] >= 0.0 and metrics[f"{prefix}side_error_phmm"] >= 0.0
    assert metrics["accuracy_dtw"] > 0.9  # the simulated actions are distinct curves
    assert metrics["markers_side_accuracy_phmm"] > 0.9  # the side flips the sign of half the features
    report = (tmp_path / "run" / "report.md").read_text()
    assert "| 1-NN DTW (tslearn) |" in report and "## markers" in report and "never on the held-out person" in report
    for name in ("confusion_angles.png", "accuracy_per_person_markers.png", "side_phi_markers.png"):
        assert (tmp_path / "run" / name).stat().st_size > 0


def test_train_and_test_folders_make_one_fold(tmp_path):
    train = write_ue_adl_folder(tmp_path / "a", ["P01", "P02"], seed=1)
    test = write_ue_adl_folder(tmp_path / "b", ["Q01"], markers=True, seed=2)
    cfg = Config(train=train, test=test, n_frames=20)
    assert available_kinds(cfg) == ["angles"]  # the training folder has no markers
    [(fold_train, fold_test)] = folds_for(cfg, "angles")
    assert fold_train.persons == ["P01", "P02"] and fold_test.persons == ["Q01"]
    assert fold_train.features.shape == (32, 20, 11) and len(fold_test.action) == 16


def test_absent_folder_is_a_clean_skip(tmp_path, capsys):
    metrics = main(["--data", str(tmp_path / "none"), "--out", str(tmp_path / "run")])
    assert metrics == {"skipped": True}
    assert "skipped, no UE-ADL data" in capsys.readouterr().err
    assert "skipped" in (tmp_path / "run" / "report.md").read_text()


def test_settings_are_chosen_without_the_held_out_person(tmp_path, monkeypatch):
    root = write_ue_adl_folder(tmp_path / "adl", ["P01", "P02", "P03"], repetitions=1)
    data = load_dataset(root, "angles", n_frames=20)
    seen = []

    def fake_fit(X, y, setting, cfg):
        return setting

    def fake_predict(model, X):
        return np.zeros(len(X), int)

    real_select = mt.select_setting

    def spy(method, X, y, persons, cfg, rng):
        seen.append(set(persons.tolist()))
        return real_select(method, X, y, persons, cfg, rng)

    monkeypatch.setitem(mt.FIT, "hmm", fake_fit)
    monkeypatch.setitem(mt.PREDICT, "hmm", fake_predict)
    monkeypatch.setattr(mt, "select_setting", spy)
    cfg = Config(grid_states=(2, 3), grid_covariance=("diag",), n_validation_folds=2)
    result = ev.run_method("hmm", ev.leave_one_person_out(data), cfg, np.random.default_rng(0))
    assert seen == [{"P02", "P03"}, {"P01", "P03"}, {"P01", "P02"}]
    assert all(len(v) == 2 for v in result.validation)  # both settings scored on inner folds
    assert set(result.per_person()) == {"P01", "P02", "P03"}


def test_config_rejects_bad_values():
    with pytest.raises(ValueError, match="^train, test"):
        Config(train="a")
    with pytest.raises(ValueError, match="^grid_covariance"):
        Config(grid_covariance=("spherical",))
    with pytest.raises(ValueError, match="^n_persons"):
        Config(n_persons=1)


def test_side_regression_reads_the_final_fingertip():
    """Markers whose right fingertip ends at x = side (0 or 1) at the frame farthest from the start and
    returns: the per-action affine baseline maps held-out trials to their side exactly; the other
    columns (not fingertips) carry a contradicting signal that it must ignore."""
    from experiments.real_arm_actions.data import Dataset, MARKER_POINTS
    rng = np.random.default_rng(0)
    names = tuple(f"{p}_{axis}" for p in MARKER_POINTS for axis in "xyz")
    side, action = np.arange(24) % 2, (np.arange(24) // 2) % 2
    features = rng.normal(0, 0.01, (24, 9, len(names)))
    features[:, :, 0] = 1 - side[:, None]  # RSHO_x: the opposite of the side, not a fingertip
    features[:, 4, names.index("RFTP_x")] += 2.0 + side
    data = Dataset(features, action, side, np.repeat(["P1", "P2"], 12), "markers", names)
    train, test = data.subset(data.person == "P1"), data.subset(data.person == "P2")
    np.testing.assert_allclose(ev.side_regression(train, test), test.side, atol=0.05)


def test_side_floor_is_chosen_on_training_persons_only(tmp_path, monkeypatch):
    """`select_side_floor` fits only on training persons (never the fold's held-out one), scores every
    floor on inner folds, and returns the floor of the lowest validation |φ − side|."""
    root = write_ue_adl_folder(tmp_path / "adl", ["P01", "P02", "P03"], markers=True, repetitions=1)
    data = load_dataset(root, "markers", n_frames=20)
    train, _ = ev.leave_one_person_out(data)[0]  # P01 held out
    seen = []
    real_models = ev._side_models

    def spy(fold_train, X_train, setting, floor, cfg):
        seen.append(set(fold_train.person.tolist()))
        return real_models(fold_train, X_train, setting, floor, cfg)

    monkeypatch.setattr(ev, "_side_models", spy)
    cfg = Config(side_floors=(0.01, 10.0), n_validation_folds=2, n_frames=20, n_iter=3, recognition_steps=2)
    floor, scores = ev.select_side_floor(train, mt.Setting(2, "diag"), cfg, np.random.default_rng(0))
    assert set(scores) == {"0.01", "10.0"} and all(0.0 <= v <= 1.2 for v in scores.values())
    assert floor == min(cfg.side_floors, key=lambda f: scores[str(f)])
    assert len(seen) == 4 and all(len(s) == 1 and "P01" not in s for s in seen)
    with pytest.raises(ValueError, match="^side_floors"):
        Config(side_floors=(0.0,))
