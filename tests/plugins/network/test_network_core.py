"""The camera-network paper's exchange types, similarity, linkers, dropout and ensemble
(pftrack_network)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from pftrack_network.linkers import (
    DEFAULT_PATH_COST,
    ENSEMBLE_PATH_COST,
    NA,
    GreedyLinker,
    MinCostFlowLinker,
    TrajectoryEnsemble,
    ensemble_distance,
    labels_from_links,
)
from pftrack_network.network import CameraNetwork, Tracklet, camera_dropout
from pftrack_network.similarity import (
    appearance_matrix,
    hsv_histograms,
    image_histogram,
    similarity_matrix,
    transit_matrix,
)


def _patch(bgr, h=40, w=20):
    return np.full((h, w, 3), bgr, dtype=np.uint8)


def _line_network():
    """a - b - c in a row, mean transit 60 s per hop, and a second a-b route of 200 s."""
    net = CameraNetwork()
    for i, c in enumerate("abc"):
        net.add_camera(c, 100.0 * i, 0.0)
    net.add_edge("a", "b", 10.0, 6.0)
    net.add_edge("b", "c", 10.0, 6.0)
    net.add_edge("a", "b", 20.0, 10.0)
    return net


# -- network --------------------------------------------------------------------------------


def test_network_round_trips_through_json_and_yaml_with_parallel_edges(tmp_path):
    net = _line_network()
    assert net.edge_params("a", "b") == [(10.0, 6.0), (20.0, 10.0)]
    assert net.edge_params("a", "c") == []
    for name in ("net.json", "net.yaml"):
        path = net.save(tmp_path / name)
        back = CameraNetwork.load(path)
        assert back.to_dict() == net.to_dict()
        assert back.number_of_edges() == 3
    assert json.loads((tmp_path / "net.json").read_text())["format"] == "pftrack-camera-network"


def test_network_file_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"format": "pftrack-camera-network", "version": 1,
                               "cameras": [{"name": "a"}], "edges": [{"u": "a", "v": "z",
                                                                       "k": 1, "theta_s": 1}]}))
    with pytest.raises(ValueError, match="bad.json.*'z'"):
        CameraNetwork.load(bad)
    with pytest.raises(FileNotFoundError, match="missing.yaml"):
        CameraNetwork.load(tmp_path / "missing.yaml")
    with pytest.raises(ValueError, match="k=-1"):
        _line_network().add_edge("a", "c", -1, 2)
    with pytest.raises(ValueError, match=r"\.txt"):
        _line_network().save(tmp_path / "net.txt")


def test_tracklet_rejects_bad_times_and_images():
    with pytest.raises(ValueError, match="t_end_s"):
        Tracklet("a", 10.0, 5.0)
    with pytest.raises(ValueError, match="image 0"):
        Tracklet("a", 0.0, 1.0, [np.zeros((4, 4), np.uint8)])


def test_dropout_joins_neighbours_with_summed_parameters_and_keeps_existing_edges():
    # a square a-b-c-d-a plus a diagonal b-d; dropping a joins b and d a second time
    net = CameraNetwork()
    for c in "abcd":
        net.add_camera(c)
    net.add_edge("a", "b", 2.0, 3.0)
    net.add_edge("a", "d", 4.0, 5.0)
    net.add_edge("b", "c", 1.0, 1.0)
    net.add_edge("c", "d", 1.0, 1.0)
    net.add_edge("b", "d", 7.0, 7.0)
    # find a seed whose first pick is "a"
    seed = next(s for s in range(100)
                if camera_dropout(net, 1, np.random.default_rng(s))[1] == ["a"])
    sub, dropped = camera_dropout(net, 1, np.random.default_rng(seed))
    assert dropped == ["a"] and "a" not in sub.cameras
    assert sorted(sub.edge_params("b", "d")) == [(6.0, 8.0), (7.0, 7.0)]
    assert net.number_of_edges() == 5  # the original is untouched
    sub_m, _ = camera_dropout(net, 1, np.random.default_rng(seed), transit_sum="moments")
    k, theta = min(sub_m.edge_params("b", "d"))
    assert k * theta == pytest.approx(2 * 3 + 4 * 5)  # means add
    assert k * theta ** 2 == pytest.approx(2 * 9 + 4 * 25)  # variances add


def test_dropout_is_seeded_and_capped():
    from pftrack_network.virtual import random_network

    net = random_network(np.random.default_rng(3), 16)
    a = camera_dropout(net, 9, np.random.default_rng(7))
    b = camera_dropout(net, 9, np.random.default_rng(7))
    assert a[1] == b[1] and a[0].to_dict() == b[0].to_dict()
    assert len(set(a[1])) == 9 and len(a[0].cameras) == 7
    for u in a[0].cameras:
        for v in a[0].cameras:
            assert len(a[0].edge_params(u, v)) <= 4
    with pytest.raises(ValueError, match="n_dropped=16"):
        camera_dropout(net, 16, np.random.default_rng(0))


def test_network_picture_is_written(tmp_path):
    sub, dropped = camera_dropout(_line_network(), 1, np.random.default_rng(0))
    path = sub.save_picture(tmp_path / "net.png", dropped=dropped, reference=_line_network())
    import cv2

    img = cv2.imread(str(path))
    assert img is not None and img.shape[0] > 200 and img.std() > 10


# -- similarity -----------------------------------------------------------------------------


def test_histogram_uses_the_central_half_only():
    img = _patch((0, 0, 255), 40, 20)  # red border ...
    img[10:30, 5:15] = (255, 0, 0)  # ... blue centre (exactly the central half)
    same_centre = _patch((0, 255, 0), 40, 20)
    same_centre[10:30, 5:15] = (255, 0, 0)
    h1, h2 = image_histogram(img), image_histogram(same_centre)
    assert h1.sum() == pytest.approx(1.0)
    assert np.minimum(h1, h2).sum() == pytest.approx(1.0)
    assert np.minimum(h1, image_histogram(_patch((0, 0, 255)))).sum() == pytest.approx(0.0)


def test_appearance_matrix_is_the_max_over_image_pairs():
    rng = np.random.default_rng(0)
    ims = [rng.integers(0, 256, (30, 16, 3), dtype=np.uint8) for _ in range(7)]
    tr = [Tracklet("a", 0, 1, ims[:2]), Tracklet("b", 2, 3, ims[2:5]),
          Tracklet("c", 4, 5, ims[5:])]
    a = appearance_matrix(tr)
    hist, offsets = hsv_histograms(tr)
    assert offsets.tolist() == [0, 2, 5] and hist.shape[0] == 7
    groups = [ims[:2], ims[2:5], ims[5:]]
    for i in range(3):
        for j in range(3):
            ref = max(np.minimum(image_histogram(x), image_histogram(y)).sum()
                      for x in groups[i] for y in groups[j])
            assert a[i, j] == pytest.approx(ref, abs=1e-6)
    assert np.allclose(np.diag(a), 1.0, atol=1e-6)


def test_transit_is_the_max_gamma_pdf_over_parallel_edges_and_zero_otherwise():
    from scipy.stats import gamma

    net = _line_network()
    tr = [Tracklet("a", 0, 10, [_patch(1)]), Tracklet("b", 80, 90, [_patch(1)]),
          Tracklet("c", 150, 160, [_patch(1)]), Tracklet("z", 100, 110, [_patch(1)])]
    t = transit_matrix(tr, net)
    ab = max(gamma.pdf(70, 10, scale=6), gamma.pdf(70, 20, scale=10))
    assert t[0, 1] == pytest.approx(ab)
    assert t[1, 2] == pytest.approx(gamma.pdf(60, 10, scale=6))
    assert t[1, 0] == 0.0  # negative time
    assert t[0, 2] == 0.0  # no edge a-c
    assert not t[3].any() and not t[:, 3].any()  # camera z not in the network
    s = similarity_matrix(tr, net)
    assert s[0, 1] == pytest.approx(ab)  # identical images: appearance 1


# -- linkers --------------------------------------------------------------------------------


def _two_people():
    """Two people walking a -> b -> c, a minute apart, red and blue."""
    net = _line_network()
    red, blue = _patch((0, 0, 200)), _patch((200, 0, 0))
    tr = [Tracklet("a", 0, 10, [red], person=0), Tracklet("a", 30, 40, [blue], person=1),
          Tracklet("b", 70, 80, [red], person=0), Tracklet("b", 100, 110, [blue], person=1),
          Tracklet("c", 140, 150, [red], person=0), Tracklet("c", 170, 180, [blue], person=1)]
    return net, tr


@pytest.mark.parametrize("linker", [GreedyLinker(), MinCostFlowLinker()])
def test_linkers_recover_two_people(linker):
    net, tr = _two_people()
    labels = linker.link(tr, net)
    assert labels.tolist() == [0, 1, 0, 1, 0, 1]


def test_min_cost_flow_finds_the_number_of_people_by_itself():
    net, tr = _two_people()
    # a link whose cost exceeds a trajectory break is not taken: six people
    assert MinCostFlowLinker(path_cost=0.0).link(tr, net).tolist() == [0, 1, 2, 3, 4, 5]
    # dropping camera b's tracklets (b not in the network) leaves NA and splits the paths
    sub = CameraNetwork()
    sub.add_camera("a")
    sub.add_camera("c")
    assert MinCostFlowLinker().link(tr, sub).tolist() == [0, 1, NA, NA, 2, 3]


def test_min_cost_flow_beats_greedy_where_greedy_is_short_sighted():
    # j0 prefers i1 a little, j1 can only follow i1: greedy takes i1 -> j0 and strands j1
    sim = np.zeros((4, 4))
    sim[0, 2], sim[1, 2], sim[1, 3] = 0.5, 0.6, 0.55
    start = np.array([0.0, 1.0, 10.0, 11.0])
    active = np.ones(4, bool)
    g = GreedyLinker(path_cost=3.0).link_matrix(sim, start, active)
    m = MinCostFlowLinker(path_cost=3.0).link_matrix(sim, start, active)
    assert g.tolist() == [0, 1, 1, 2]  # three trajectories
    assert m.tolist() == [0, 1, 0, 1]  # two, total cost -log .5 - log .55 < -log .6 + break


def test_labels_from_links_numbers_in_tracklet_order():
    labels = labels_from_links(5, np.array([3, 0]), np.array([4, 3]),
                               np.array([True, True, False, True, True]))
    assert labels.tolist() == [0, 1, NA, 0, 0]


def test_ensemble_distance_ignores_na():
    runs = np.array([[0, 0, NA, 1],
                     [0, 1, 2, 1],
                     [NA, 1, 2, NA]])
    d = ensemble_distance(runs)
    ref = np.zeros((3, 3))
    for i in range(3):
        for j in range(3):
            ref[i, j] = sum(a != b for a, b in zip(runs[i], runs[j]) if a != NA and b != NA)
    assert np.array_equal(d, ref)
    assert d[0, 1] == 1 and d[1, 2] == 0 and d[0, 2] == 1


def test_trajectory_ensemble_k_and_clusters_from_runs():
    runs = np.array([[0, 0, 0, NA], [0, 0, 1, 0], [1, 1, 2, 1], [1, 1, 2, NA]])
    te = TrajectoryEnsemble()
    labels = te.combine(runs)
    assert te.n_clusters_ == 2  # runs hold 2, 2, 3, 1 trajectories: mean 2
    assert labels[0] == labels[1] != labels[2] == labels[3]


def test_trajectory_ensemble_is_seeded_and_records_runs():
    _net, tr = _two_people()
    big = _line_network()
    big.add_camera("d", 300, 0)
    big.add_edge("c", "d", 10, 6)
    te = TrajectoryEnsemble(n_dropped=1, n_subnetworks=6)
    a = te.link(tr, big, rng=np.random.default_rng(5))
    runs = te.run_labels_.copy()
    b = te.link(tr, big, rng=np.random.default_rng(5))
    assert a.tolist() == b.tolist() and np.array_equal(runs, te.run_labels_)
    assert runs.shape == (6, 6) and len(te.dropped_) == 6
    for s, dropped in enumerate(te.dropped_):  # NA exactly on the dropped cameras
        assert ((runs[:, s] == NA) == np.array([t.camera in dropped for t in tr])).all()
    with pytest.raises(ValueError, match="rng"):
        te.link(tr, big)


def test_min_cost_flow_candidates_keep_the_next_tracklets_of_each_camera():
    from pftrack_network.linkers import _next_in_camera

    cams = np.array(["a", "b", "b", "b", "c"])
    start = np.array([0.0, 20.0, 30.0, 40.0, 25.0])
    end = start + 5
    keep = _next_in_camera(cams, start, end, 2)
    assert np.flatnonzero(keep[0]).tolist() == [1, 2, 4]  # b's first two after 5 s, c's one
    assert np.flatnonzero(keep[1]).tolist() == [2, 3]  # after 25 s: b at 30 and 40, not c (25)
    # two people, the second half a minute behind: one candidate per camera leaves the second
    # person only the first one's tracklets to follow (all refused), two recover both
    net, tr = _two_people()
    assert MinCostFlowLinker(candidates=1).link(tr, net).tolist() == [0, 1, 0, 2, 0, 3]
    assert MinCostFlowLinker(candidates=2).link(tr, net).tolist() == [0, 1, 0, 1, 0, 1]
    with pytest.raises(ValueError, match="candidates"):
        MinCostFlowLinker(candidates=0).link(tr, net)


@pytest.mark.parametrize("linker", [GreedyLinker(path_cost=3.0), MinCostFlowLinker(path_cost=3.0)])
def test_linkers_only_link_forward_in_time(linker):
    # a symmetric similarity (a cycle 0 <-> 1) still gives one forward link
    sim = np.array([[0.0, 0.9], [0.9, 0.0]])
    labels = linker.link_matrix(sim, np.array([0.0, 5.0]), np.ones(2, bool))
    assert labels.tolist() == [0, 0]
    # equal start times: never linked
    labels = linker.link_matrix(sim, np.array([0.0, 0.0]), np.ones(2, bool))
    assert labels.tolist() == [0, 1]


def _one_person_over_b():
    """a - b - c, 60 s mean transit per hop (k 10, theta 6); one person: a 0-10 s, b 70-80 s,
    c 140-150 s (130 s from leaving a to entering c, over b)."""
    net = CameraNetwork()
    for i, c in enumerate("abc"):
        net.add_camera(c, 100.0 * i, 0.0)
    net.add_edge("a", "b", 10.0, 6.0)
    net.add_edge("b", "c", 10.0, 6.0)
    red = _patch((0, 0, 200))
    tr = [Tracklet("a", 0, 10, [red], person=0), Tracklet("b", 70, 80, [red], person=0),
          Tracklet("c", 140, 150, [red], person=0)]
    return net, tr


def test_ensemble_sub_networks_link_across_a_dropped_camera_by_moments_not_by_parameters():
    net, tr = _one_person_over_b()
    seed = next(s for s in range(100)
                if camera_dropout(net, 1, np.random.default_rng(s))[1] == ["b"])
    by = {how: camera_dropout(net, 1, np.random.default_rng(seed), transit_sum=how)[0]
          for how in ("moments", "parameters")}
    assert by["moments"].edge_params("a", "c") == [(pytest.approx(20.0), pytest.approx(6.0))]
    assert by["parameters"].edge_params("a", "c") == [(20.0, 12.0)]  # mean 240 s, not 120
    from scipy.stats import gamma

    t_m = transit_matrix(tr, by["moments"])[0, 2]
    t_p = transit_matrix(tr, by["parameters"])[0, 2]
    assert t_m == pytest.approx(gamma.pdf(130, 20, scale=6))
    assert t_p == pytest.approx(gamma.pdf(130, 20, scale=12))
    assert -np.log(t_m) < ENSEMBLE_PATH_COST < -np.log(t_p)  # ~4.3 against ~7.4
    # the sub-network's weak tracker (the ensemble's default) links a to c only by moments
    for how, linked in (("moments", True), ("parameters", False)):
        te = TrajectoryEnsemble(n_dropped=1, n_subnetworks=1, transit_sum=how)
        te.link(tr, net, rng=np.random.default_rng(seed))
        assert te.dropped_ == [["b"]]
        runs = te.run_labels_[:, 0]
        assert runs[1] == NA and bool(runs[0] == runs[2]) == linked


def test_trajectory_ensemble_defaults_are_the_tuned_ones():
    te = TrajectoryEnsemble()
    assert (te.n_dropped, te.n_subnetworks, te.transit_sum, te.linkage) == (
        9, 100, "moments", "average")
    # the sub-networks' break cost is below the full network's (links more sparingly)
    assert ENSEMBLE_PATH_COST < DEFAULT_PATH_COST


def test_gated_ensemble_defaults_are_the_tuned_ones():
    """The named change of method's defaults are the choices of the tuning seeds (the
    protocol without image reuse), and the benchmark's tuned gated row uses the same C_d."""
    from pftrack_bench.camera_network import GATED_DROPPED as BENCH_GATED_DROPPED
    from pftrack_network.linkers import (
        GATED_DROPPED,
        GATED_PATH_COST,
        JOIN_MIN_APPEARANCE,
        GatedTrajectoryEnsemble,
    )

    te = GatedTrajectoryEnsemble()
    assert (te.n_dropped, te.n_subnetworks, te.join_min_appearance, te.distance) == (
        5, 100, 0.65, "share")
    assert te.n_dropped == GATED_DROPPED == BENCH_GATED_DROPPED
    assert te.join_min_appearance == JOIN_MIN_APPEARANCE
    assert te.default_linker().path_cost == GATED_PATH_COST == 6.75


# -- changes of method: joined edges marked, appearance-gated joins, the share distance -----


def test_dropout_marks_the_edges_it_joins_and_transit_splits_by_them():
    from pftrack_network.similarity import transit_matrices

    net, tr = _one_person_over_b()
    net.add_edge("a", "c", 30.0, 5.0)  # a real a-c route beside the one dropout will join
    assert not net.joined_edges().any()
    seed = next(s for s in range(100)
                if camera_dropout(net, 1, np.random.default_rng(s))[1] == ["b"])
    sub, _ = camera_dropout(net, 1, np.random.default_rng(seed), transit_sum="moments")
    assert sub.joined_edges().tolist() == [False, True]  # a-c: the real one, then the joined
    original, joined = transit_matrices(tr, sub)
    from scipy.stats import gamma

    assert original[0, 2] == pytest.approx(gamma.pdf(130, 30, scale=5))
    assert joined[0, 2] == pytest.approx(gamma.pdf(130, 20, scale=6))
    assert np.array_equal(np.maximum(original, joined), transit_matrix(tr, sub))
    assert np.array_equal(transit_matrix(tr, sub, edges="joined"), joined)
    assert np.array_equal(transit_matrix(tr, sub, edges="original"), original)
    with pytest.raises(ValueError, match="edges must be"):
        transit_matrix(tr, sub, edges="new")


@pytest.mark.parametrize("gate, linked", [(None, True), (0.5, True), (0.7, False)])
def test_gated_joins_link_over_a_dropped_camera_only_with_enough_appearance(gate, linked):
    net, tr = _one_person_over_b()
    seed = next(s for s in range(100)
                if camera_dropout(net, 1, np.random.default_rng(s))[1] == ["b"])
    app = np.full((3, 3), 0.6)  # a and c look 0.6 alike: links over the joined a-c edge
    te = TrajectoryEnsemble(n_dropped=1, n_subnetworks=1, join_min_appearance=gate)
    te.link(tr, net, appearance=app, rng=np.random.default_rng(seed))
    runs = te.run_labels_[:, 0]
    assert te.dropped_ == [["b"]] and runs[1] == NA
    assert bool(runs[0] == runs[2]) == linked
    # a real edge is never gated: with b kept, a -> b -> c links whatever the gate
    keep_b = next(s for s in range(100)
                  if camera_dropout(net, 1, np.random.default_rng(s))[1] == ["c"])
    te.link(tr, net, appearance=app, rng=np.random.default_rng(keep_b))
    assert te.run_labels_[0, 0] == te.run_labels_[1, 0] != NA
    with pytest.raises(ValueError, match="join_min_appearance"):
        TrajectoryEnsemble(join_min_appearance=float("nan")).link(
            tr, net, appearance=app, rng=np.random.default_rng(0))


def test_share_distance_divides_by_the_runs_both_were_tracked():
    runs = np.array([[0, 0, NA, 1],
                     [0, 1, 2, 1],
                     [NA, 1, 2, NA],
                     [NA, NA, NA, NA]])
    d = ensemble_distance(runs, normalise=True)
    # 0-1: both in runs 0, 1, 3, disagree in run 1; 1-2: both in runs 1, 2, agree; 0-2: run 1
    assert d[0, 1] == pytest.approx(1 / 3) and d[1, 2] == 0 and d[0, 2] == 1
    assert d[3, 0] == d[3, 1] == 1  # never tracked together: as far as can be
    assert np.array_equal(d, d.T) and np.all(np.diag(d) == 0)
    with pytest.raises(ValueError, match="distance"):
        net, tr = _one_person_over_b()
        TrajectoryEnsemble(distance="ratio").link(tr, net, rng=np.random.default_rng(0))
