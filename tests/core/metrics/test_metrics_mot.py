"""CLEAR / Identity / HOTA (pftrack.metrics): parity with TrackEval and py-motmetrics on real
MOTChallenge data, behaviour on constructed cases, world-coordinate scoring on PETS09, the CLI."""

from __future__ import annotations

import contextlib
import importlib.metadata
import io
import json
from pathlib import Path

import numpy as np
import pytest
from pftrack.cli import main
from pftrack.io.data import data_path
from pftrack.io.mot import CONF, ID, LEFT, X, Y, read_mot, write_mot
from pftrack.metrics import (
    clear_metrics,
    evaluate,
    hota_metrics,
    identity_matching,
    identity_metrics,
    prepare_sequence,
)


def _motmetrics_file(seq: str, name: str) -> Path:
    try:
        dist = importlib.metadata.distribution("motmetrics")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("motmetrics (test extra, for its TUD data files) is not installed")
    return Path(dist.locate_file(f"motmetrics/data/{seq}/{name}"))


@pytest.fixture(scope="module")
def tud():
    return {s: (read_mot(_motmetrics_file(s, "gt.txt")), read_mot(_motmetrics_file(s, "test.txt")))
            for s in ("TUD-Campus", "TUD-Stadtmitte")}


@pytest.fixture(scope="module")
def pets_gt() -> np.ndarray:
    return read_mot(data_path("pets09", "gt.txt"))


# -- parity with the published figures ---------------------------------------------------------

# py-motmetrics 1.4.0, tests/test_metrics.py::test_motchallenge_files (IoU distance <= 0.5, no gt
# filtering), and TrackEval 1.3 (HOTA): idf1, idp, idr, recall, precision, gt ids, MT, PT, ML,
# FP, FN, IDSW, Frag, MOTA, MOTP as motmetrics' mean distance 1 - IoU; HOTA
PUBLISHED = {
    "TUD-Campus": (0.557659, 0.729730, 0.451253, 0.582173, 0.941441, 8, 1, 6, 1, 13, 150, 7, 7,
                   0.526462, 0.277201, 0.391397),
    "TUD-Stadtmitte": (0.644619, 0.819760, 0.531142, 0.608997, 0.939920, 10, 5, 4, 1, 45, 452, 7,
                       6, 0.564014, 0.345904, 0.397849),
}


@pytest.mark.parametrize("seq", sorted(PUBLISHED))
def test_tud_matches_motmetrics_and_trackeval_figures(tud, seq):
    (idf1, idp, idr, rec, prec, n_ids, mt, pt, ml, fp, fn, idsw, frag, mota, motp_dist,
     hota) = PUBLISHED[seq]
    r = evaluate(*tud[seq])
    assert r["MOTA"] == pytest.approx(mota, abs=1e-6)
    assert r["IDF1"] == pytest.approx(idf1, abs=1e-6)
    assert r["HOTA"] == pytest.approx(hota, abs=1e-6)
    assert r["IDP"] == pytest.approx(idp, abs=1e-6)
    assert r["IDR"] == pytest.approx(idr, abs=1e-6)
    assert r["Recall"] == pytest.approx(rec, abs=1e-6)
    assert r["Precision"] == pytest.approx(prec, abs=1e-6)
    assert 1 - r["MOTP"] == pytest.approx(motp_dist, abs=1e-6)  # motmetrics reports 1 - IoU
    assert (r["num_gt_ids"], r["MT"], r["PT"], r["ML"], r["FP"], r["FN"], r["IDSW"], r["Frag"]) == \
        (n_ids, mt, pt, ml, fp, fn, idsw, frag)
    assert r["HOTA"] == pytest.approx(np.sqrt(r["DetA"] * r["AssA"]), rel=0.05)
    assert r["num_ignored_gt"] == 0


def _trackeval():
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it prints about optional datasets
            import trackeval
    except ImportError as exc:  # pragma: no cover - depends on the environment
        pytest.skip(f"trackeval does not import: {exc}")
    return trackeval


def _compare_with_trackeval(seq_data, threshold=0.5):
    te = _trackeval()
    data = seq_data.to_trackeval()
    with contextlib.redirect_stdout(io.StringIO()):
        cfg = {"THRESHOLD": threshold, "PRINT_CONFIG": False}
        ref_c = te.metrics.CLEAR(cfg).eval_sequence(data)
        ref_i = te.metrics.Identity(cfg).eval_sequence(data)
        ref_h = te.metrics.HOTA().eval_sequence(data)
    c = clear_metrics(seq_data, threshold)
    i = identity_metrics(seq_data, threshold)
    h = hota_metrics(seq_data)
    for k in ("CLR_TP", "CLR_FN", "CLR_FP", "IDSW", "MT", "PT", "ML", "Frag"):
        assert c[k] == ref_c[k], k
    for k in ("MOTA", "MOTP", "MODA", "sMOTA", "CLR_Re", "CLR_Pr", "MTR", "MLR"):
        assert c[k] == pytest.approx(ref_c[k], abs=1e-12), k
    for k in ("IDTP", "IDFN", "IDFP"):
        assert i[k] == ref_i[k], k
    for k in ("IDF1", "IDP", "IDR"):
        assert i[k] == pytest.approx(ref_i[k], abs=1e-12), k
    for k in ("HOTA_TP", "HOTA_FN", "HOTA_FP"):
        np.testing.assert_array_equal(h[k], ref_h[k], err_msg=k)
    for k in ("HOTA", "DetA", "AssA", "LocA", "DetRe", "DetPr", "AssRe", "AssPr", "OWTA"):
        np.testing.assert_allclose(h[k], ref_h[k], atol=1e-10, err_msg=k)
    return c, i, h


@pytest.mark.parametrize("seq", ["TUD-Campus", "TUD-Stadtmitte"])
def test_tud_equals_trackeval_classes(tud, seq):
    _, _, h = _compare_with_trackeval(prepare_sequence(*tud[seq]))
    assert np.mean(h["HOTA"]) == pytest.approx(PUBLISHED[seq][-1], abs=1e-4)


def _noisy_tracks(gt: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A plausible tracker output made from gt: jitter, misses, false boxes, id switches."""
    tr = gt[rng.random(len(gt)) > 0.1].copy()
    tr[:, LEFT:LEFT + 2] += rng.normal(0, 3, (len(tr), 2))
    tr[:, X:Y + 1] += rng.normal(0, 0.3, (len(tr), 2))
    late = tr[:, 0] > 400
    tr[late & (tr[:, ID] == 1), ID] = 101  # a track that changes identity
    swap = (tr[:, 0] > 500) & np.isin(tr[:, ID], [3, 4])
    tr[swap, ID] = 7 - tr[swap, ID]  # two tracks exchange identities
    fa = gt[rng.choice(len(gt), 200, replace=False)].copy()
    fa[:, LEFT] += 200
    fa[:, X] += 5
    fa[:, ID] = 500 + np.arange(200) // 20
    _, keep = np.unique(np.column_stack([fa[:, 0], fa[:, ID]]), axis=0, return_index=True)
    return np.vstack([tr, fa[keep]])


@pytest.mark.parametrize("metric", ["iou", "world"])
def test_pets_noisy_tracks_equal_trackeval_classes(pets_gt, metric):
    tracks = _noisy_tracks(pets_gt, np.random.default_rng(7))
    seq = prepare_sequence(pets_gt, tracks, metric=metric,
                           zero_distance_m=2.0 if metric == "world" else None)
    c, _, h = _compare_with_trackeval(seq)
    assert 0.3 < c["MOTA"] < 0.95 and c["IDSW"] > 0 and 0.3 < np.mean(h["HOTA"]) < 0.95


# -- behaviour ------------------------------------------------------------------------------------

def test_perfect_tracks_score_one(tud, pets_gt):
    gt = tud["TUD-Campus"][0]
    r = evaluate(gt, gt)
    for k in ("MOTA", "MOTP", "IDF1", "IDP", "IDR", "HOTA", "DetA", "AssA", "LocA"):
        assert r[k] == pytest.approx(1.0, abs=1e-12), k
    assert (r["IDSW"], r["FP"], r["FN"], r["TP"]) == (0, 0, 0, len(gt))
    relabelled = gt.copy()
    relabelled[:, ID] += 1000  # ids are arbitrary labels
    assert evaluate(gt, relabelled)["HOTA"] == pytest.approx(1.0)
    w = evaluate(pets_gt, pets_gt, metric="world")
    assert (w["MOTA"], w["IDF1"], w["HOTA"], w["MOTP_m"]) == pytest.approx((1, 1, 1, 0))


def _box_track(frames, tid, x0=0.0, dx=0.0, y=0.0):
    f = np.asarray(frames, float)
    return np.column_stack([f, np.full_like(f, tid), x0 + dx * (f - f[0]), np.full_like(f, y),
                            np.full_like(f, 20), np.full_like(f, 40)])


def test_one_track_changing_id_is_one_switch():
    gt = _box_track(range(1, 11), 1)
    tr = np.vstack([_box_track(range(1, 6), 7), _box_track(range(6, 11), 8)])
    r = evaluate(gt, tr)
    assert (r["IDSW"], r["FP"], r["FN"], r["TP"]) == (1, 0, 0, 10)
    assert r["MOTA"] == pytest.approx(0.9)
    assert r["IDF1"] == pytest.approx(0.5)  # 5 of 10 boxes under the best single id
    # HOTA: DetA 1; AssA = mean over TPs of |TPA| / (|gt| + |pr| - |TPA|) = 5 / (10 + 5 - 5)
    assert r["DetA"] == pytest.approx(1.0) and r["AssA"] == pytest.approx(0.5)
    assert r["HOTA"] == pytest.approx(np.sqrt(0.5))


def test_two_targets_swapping_ids_are_two_switches():
    gt = np.vstack([_box_track(range(1, 11), 1, y=0), _box_track(range(1, 11), 2, y=200)])
    tr = gt.copy()
    late = tr[:, 0] > 5
    tr[late, ID] = 3 - tr[late, ID]
    r = evaluate(gt, tr)
    assert (r["IDSW"], r["FP"], r["FN"]) == (2, 0, 0)
    assert r["MOTA"] == pytest.approx(0.9) and r["IDF1"] == pytest.approx(0.5)


def test_clear_keeps_the_previous_match_over_a_better_overlap():
    gt = _box_track([1, 2], 1)
    tr = np.vstack([_box_track([1, 2], 5), _box_track([2], 6)])
    tr[1, LEFT] = 5.0   # frame 2: track 5 IoU 15/25 = 0.6 ...
    tr[2, LEFT] = 1.0   # ... track 6 IoU 19/21 = 0.905 but new
    r = evaluate(gt, tr)
    assert (r["IDSW"], r["FP"], r["TP"]) == (0, 1, 2)
    assert r["MOTP"] == pytest.approx((1.0 + 0.6) / 2)
    assert r["MOTA"] == pytest.approx(0.5)


def test_iou_threshold_decides_matches():
    gt = _box_track(range(1, 5), 1)
    tr = _box_track(range(1, 5), 1)
    tr[:, LEFT] += 10.0  # IoU 10*40 / (2*800 - 400) = 1/3
    assert evaluate(gt, tr)["TP"] == 0
    r = evaluate(gt, tr, threshold=0.3)
    assert r["TP"] == 4 and r["MOTP"] == pytest.approx(1 / 3)
    # HOTA sweeps alpha: 1/3 passes alphas 0.05..0.30 (6 of 19)
    assert evaluate(gt, tr)["HOTA"] == pytest.approx(6 / 19)


def test_empty_tracks_and_empty_gt():
    gt = _box_track(range(1, 5), 1)
    r = evaluate(gt, np.zeros((0, 10)))
    assert (r["FN"], r["FP"], r["MOTA"], r["IDF1"], r["HOTA"], r["ML"]) == (4, 0, 0, 0, 0, 1)
    r = evaluate(np.zeros((0, 10)), gt)
    assert (r["FN"], r["FP"], r["HOTA"]) == (0, 4, 0)


def test_pets_world_metric_with_shifted_tracks(pets_gt):
    keep = pets_gt[:, CONF] != 0
    n = int(keep.sum())
    shifted = pets_gt.copy()
    shifted[:, X] += 0.12
    shifted[:, Y] += 0.16  # 0.2 m on the ground plane
    r = evaluate(pets_gt, shifted, metric="world")  # hit within 1 m, similarity 1 - d / 2
    assert (r["MOTA"], r["IDF1"], r["TP"]) == pytest.approx((1.0, 1.0, n))
    assert r["MOTP"] == pytest.approx(0.9) and r["MOTP_m"] == pytest.approx(0.2)
    r = evaluate(pets_gt, shifted, metric="world", threshold=1.1)  # similarity 1 - 0.2/2.2
    assert r["HOTA"] == pytest.approx(18 / 19) and r["LocA"] == pytest.approx(
        (18 * (1 - 0.2 / 2.2) + 1) / 19)
    # one person tracked 1.25 m off: no CLEAR match within 1 m, but HOTA credits alphas <= 0.375
    one = pets_gt[pets_gt[:, ID] == 1]
    far = one.copy()
    far[:, X] += 0.75
    far[:, Y] += 1.0
    r = evaluate(one, far, metric="world")
    assert (r["TP"], r["MOTA"], r["IDF1"]) == pytest.approx((0, -1.0, 0.0))
    assert r["HOTA"] == pytest.approx(7 / 19)
    # the image boxes are untouched, so the IoU metric is perfect
    assert evaluate(one, far)["MOTA"] == pytest.approx(1.0)


def test_zero_marked_gt_policies(pets_gt):
    n_all, n_zero = len(pets_gt), int(np.sum(pets_gt[:, CONF] == 0))
    assert n_zero == 174
    r = evaluate(pets_gt, pets_gt)  # drop_matched
    assert (r["num_ignored_gt"], r["num_ignored_tracker"], r["MOTA"]) == (174, 174, 1.0)
    r = evaluate(pets_gt, pets_gt, zero_marked="drop")  # TrackEval MOT15
    assert r["FP"] == n_zero and r["MOTA"] == pytest.approx(1 - n_zero / (n_all - n_zero))
    r = evaluate(pets_gt, pets_gt, zero_marked="keep")  # py-motmetrics default
    assert r["TP"] == n_all and r["MOTA"] == 1.0
    # a track on an ignored person that does not overlap it stays a false positive
    ghost = pets_gt[pets_gt[:, CONF] == 0][:1].copy()
    ghost[:, LEFT] += 300
    ghost[:, ID] = 999
    r = evaluate(pets_gt, np.vstack([pets_gt[pets_gt[:, CONF] != 0], ghost]))
    assert (r["FP"], r["num_ignored_tracker"]) == (1, 0)


def test_identity_matching_maps_original_ids():
    gt = np.vstack([_box_track(range(1, 11), 1, y=0), _box_track(range(1, 11), 2, y=200)])
    tr = gt.copy()
    tr[:, ID] = np.where(tr[:, ID] == 1, 42, 17)
    assert identity_matching(prepare_sequence(gt, tr)) == {1: 42, 2: 17}


def test_bad_arguments_are_named():
    gt = _box_track(range(1, 3), 1)
    with pytest.raises(ValueError, match="metric"):
        evaluate(gt, gt, metric="giou")
    with pytest.raises(ValueError, match="threshold"):
        evaluate(gt, gt, threshold=1.5)
    with pytest.raises(ValueError, match="zero_marked"):
        evaluate(gt, gt, zero_marked="ignore")
    with pytest.raises(ValueError, match="no world position"):
        evaluate(gt, gt, metric="world")
    dup = np.vstack([gt, gt[:1]])
    with pytest.raises(ValueError, match="track rows: id 1 appears twice in frame 1"):
        evaluate(gt, dup)


# -- command line --------------------------------------------------------------------------------

def test_cli_json_and_table(tud, tmp_path, capsys):
    gt = _motmetrics_file("TUD-Campus", "gt.txt")
    tracks = _motmetrics_file("TUD-Campus", "test.txt")
    out = tmp_path / "scores.json"
    assert main(["eval", str(gt), str(tracks), "--json", "--out", str(out)]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert printed == json.loads(out.read_text())
    for k in ("MOTA", "MOTP", "IDF1", "IDP", "IDR", "IDSW", "HOTA", "DetA", "AssA"):
        assert k in printed
    assert printed["MOTA"] == pytest.approx(0.526462, abs=1e-6)
    assert main(["eval", str(gt), str(tracks)]) == 0
    table = capsys.readouterr().out
    assert "HOTA" in table and "39.14" in table and "52.65" in table


def test_cli_world_and_errors(pets_gt, tmp_path, capsys):
    gt = data_path("pets09", "gt.txt")
    shifted = pets_gt.copy()
    shifted[:, X] += 0.3
    tr = write_mot(tmp_path / "tracks.txt", shifted)
    assert main(["eval", str(gt), str(tr), "--metric", "world", "--threshold", "0.5",
                 "--json"]) == 0
    r = json.loads(capsys.readouterr().out)
    assert r["MOTA"] == pytest.approx(1.0) and r["MOTP_m"] == pytest.approx(0.3)
    bad = tmp_path / "bad.txt"
    bad.write_text("1,1,0,0,10,10\n1,2,0,0\n")
    assert main(["eval", str(gt), str(bad)]) == 2
    assert f"{bad}, line 2" in capsys.readouterr().err
    assert main(["eval", str(tmp_path / "none.txt"), str(gt)]) == 2
    assert "none.txt" in capsys.readouterr().err
