"""motionrep.torch datasets (issue 22, item 5): windows, resampling, extra targets, statistics file, split,
augmentation, lazy reading in DataLoader workers, and the batch sampler's one-pass-per-epoch promise.

Fixtures are small synthetic clips the tests write; the one real-data test is marked ``realdata``.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="motionrep.torch needs torch (pip install 'motionrep[torch]')")

from helpers import SHARED_DATA, requires_shared  # noqa: E402

from motionrep.errors import FormatError, ValidationError  # noqa: E402
from motionrep.io import write, write_database  # noqa: E402
from motionrep.model.kinematics import global_positions  # noqa: E402
from motionrep.model.ops import resample, resampled_count  # noqa: E402
from motionrep.plugin.registry import get_representation  # noqa: E402
from motionrep.model.synthetic import chain_skeleton, humanoid_skeleton, synthetic_motion  # noqa: E402
from motionrep.torch import FeatureStats, MotionDataset, WindowSampler, split_clips  # noqa: E402
from motionrep.torch._augment import mirror_pairs  # noqa: E402

FRAMES = (50, 37, 64, 20)  # one clip shorter than a window


def _clips(skeleton=None):
    return {f"clip{i}": synthetic_motion(skeleton, frames=n, fps=60.0, seed=i) for i, n in enumerate(FRAMES)}


@pytest.fixture(scope="module")
def bvh_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("bvh")
    for name, m in _clips().items():
        write(m, d / f"{name}.bvh")
    return d


@pytest.fixture(scope="module")
def database(tmp_path_factory):
    path = tmp_path_factory.mktemp("db") / "clips.h5"
    write_database(_clips(), path)
    return path


def _windows(ds):
    return sorted((int(c), int(s)) for c, s in zip(ds.window_clip, ds.window_start))


def test_windows_count_stride_and_features_match_the_numpy_encoder(database):
    ds = MotionDataset(database, representation="ortho6d", length=16, stride=8, dtype=torch.float64)
    clips = _clips()
    assert ds.clip_names == list(clips)
    assert len(ds) == sum(max(0, (n - 16) // 8 + 1) for n in FRAMES)
    rep = get_representation("ortho6d")
    for i in (0, len(ds) // 2, len(ds) - 1):
        item = ds[i]
        motion = clips[ds.clip_names[int(item["clip"])]]
        s = int(item["start"])
        want = rep.to_features(motion)[s:s + 16]
        assert item["features"].shape == (16, ds.width)
        # the same numpy encoder on the same float64 values; only the HDF5 round trip is in between
        np.testing.assert_allclose(item["features"].numpy(), want, rtol=0, atol=1e-12)
    batch = ds[[0, 3, 1]]
    assert batch["features"].shape == (3, 16, ds.width)
    np.testing.assert_array_equal(batch["features"][1].numpy(), ds[3]["features"].numpy())
    with pytest.raises(IndexError):
        ds[len(ds)]


def test_directory_and_database_give_the_same_windows(bvh_dir, database):
    a = MotionDataset(bvh_dir, length=10, stride=5)
    b = MotionDataset(database, length=10, stride=5)
    assert a.clip_names == b.clip_names and len(a) == len(b)
    # BVH keeps 6 decimals of each channel: float32 features agree to that
    np.testing.assert_allclose(a[7]["features"].numpy(), b[7]["features"].numpy(), atol=1e-4)


def test_mrc_archive_source(tmp_path):
    from motionrep.io.archive import write_archive
    from motionrep.pipeline.compress import compress_motion

    m = synthetic_motion(frames=40, fps=30.0)
    path = tmp_path / "clips.h5"
    write_archive({"a": compress_motion(m, "transform").data}, path)
    ds = MotionDataset(path, length=8)
    assert ds.clip_names == ["a"] and len(ds) == 5
    assert ds[4]["features"].shape == (8, ds.width)


def test_resampling_to_fps(database):
    ds = MotionDataset(database, length=10, stride=10, fps=24.0, dtype=torch.float64)
    counts = [resampled_count(n, 60.0, 24.0) for n in FRAMES]
    assert [c.frames for c in ds.clips] == counts
    assert len(ds) == sum(max(0, (n - 10) // 10 + 1) for n in counts)
    motion = resample(_clips()["clip0"], 24.0)
    want = get_representation("root-quat-axis-angle").to_features(motion)[10:20]
    np.testing.assert_allclose(ds[1]["features"].numpy(), want, atol=1e-12)  # HDF5 float64 round trip only


def test_positions_velocities_and_contacts(database):
    ds = MotionDataset(database, length=12, stride=12, positions=True, velocities=True, contacts=True,
                       contact_joints=["LeftLeg", "RightLeg"], dtype=torch.float64)
    motion = _clips()["clip0"]
    pos = global_positions(motion)
    item = ds[1]
    # float32 storage of the cached positions (file units ~100): 1e-4 relative
    np.testing.assert_allclose(item["positions"].numpy(), pos[12:24], rtol=1e-5, atol=1e-4)
    np.testing.assert_allclose(item["velocities"].numpy(), (np.gradient(pos, axis=0) * 60.0)[12:24],
                               rtol=1e-4, atol=1e-3)
    assert item["contacts"].shape == (12, 2)
    assert set(np.unique(item["contacts"].numpy())) <= {0.0, 1.0}


def test_foot_contacts_follow_height_and_speed(tmp_path):
    sk = chain_skeleton(2)  # Joint0 (root) -> Joint1
    sk = sk.replace(names=("Hips", "LeftFoot"))
    F = 60
    root = np.zeros((F, 3))
    root[:, 1] = 50.0
    root[30:, 1] += np.linspace(0, 30, 30)  # the foot rises in the second half
    rot = np.tile([0.0, 0.0, 0.0, 1.0], (F, 2, 1))
    from motionrep import Motion

    write_database({"m": Motion(sk, 30.0, root, rot)}, tmp_path / "c.h5")
    ds = MotionDataset(tmp_path / "c.h5", length=F, contacts=True, up="y")
    c = ds[0]["contacts"][:, 0].numpy()
    assert c[:29].all() and not c[32:].any()


def test_stats_file_round_trip_normalise_and_invert(tmp_path, database):
    train = split_clips(_clips(), (0.5, 0.25, 0.25), seed=3)["train"]
    ds = MotionDataset(database, length=8, clips=train, dtype=torch.float64)
    stats = ds.compute_stats()
    feats = np.concatenate([get_representation(ds.representation.name).to_features(_clips()[n]) for n in train])
    np.testing.assert_allclose(stats.mean, feats.mean(axis=0), atol=1e-9)  # float64 sums in another order
    std = feats.std(axis=0)
    np.testing.assert_allclose(stats.std, np.where(std > 1e-8 * (1 + np.abs(feats.mean(0))), std, 1.0), atol=1e-9)
    path = tmp_path / "stats.json"
    stats.save(path)
    doc = json.loads(path.read_text())
    assert doc["format"] == "motionrep-feature-stats" and doc["format_version"] == 1
    loaded = FeatureStats.load(path)
    np.testing.assert_array_equal(loaded.mean, stats.mean)  # JSON keeps Python's round-trip float text
    ds.set_stats(path)
    raw = MotionDataset(database, length=8, clips=train, dtype=torch.float64)[2]["features"]
    normed = ds[2]["features"]
    np.testing.assert_allclose(normed.numpy(), (raw.numpy() - stats.mean) / stats.std, atol=1e-12)
    np.testing.assert_allclose(ds.denormalize(normed).numpy(), raw.numpy(), atol=1e-9)
    other = MotionDataset(database, representation="euler", length=8)
    with pytest.raises(ValidationError, match="root-quat-axis-angle"):
        other.set_stats(stats)
    (tmp_path / "bad.json").write_text('{"format": "something"}')
    with pytest.raises(FormatError, match="bad.json"):
        FeatureStats.load(tmp_path / "bad.json")
    (tmp_path / "new.json").write_text(json.dumps({**doc, "format_version": 2}))
    with pytest.raises(FormatError, match="format_version"):
        FeatureStats.load(tmp_path / "new.json")


def test_split_is_deterministic_order_free_and_keeps_groups():
    names = [f"{s}_{t:02d}" for s in (60, 61) for t in range(1, 16)]
    a = split_clips(names, seed=7)
    assert split_clips(list(reversed(names)), seed=7) == {k: [n for n in reversed(names) if n in v]
                                                          for k, v in a.items()}
    assert sorted(sum(a.values(), [])) == sorted(names)
    assert len(a["train"]) == 24 and len(a["val"]) == 3 and len(a["test"]) == 3
    assert split_clips(names, seed=8) != a
    by_trial = split_clips(names, seed=7, group=lambda n: n.split("_")[1])
    for part in by_trial.values():
        trials = {n.split("_")[1] for n in part}
        assert all(f"{s}_{t}" in part for s in (60, 61) for t in trials)
    small = split_clips(["a", "b", "c"], seed=0)
    assert all(len(v) == 1 for v in small.values())
    with pytest.raises(ValidationError):
        split_clips(names, (0.5, 0.5, 0.5))
    with pytest.raises(ValidationError, match="twice"):
        split_clips(["a", "a"])


def test_mirror_pairs_from_names_and_map():
    sk = humanoid_skeleton()
    pairs = mirror_pairs(sk)
    named = {sk.names[i]: sk.names[j] for i, j in enumerate(pairs)}
    assert named["LeftArm"] == "RightArm" and named["RightLeg"] == "LeftLeg" and named["Spine"] == "Spine"
    custom = mirror_pairs(sk, {"Neck": "Head"})
    assert sk.names[custom[sk.index("Head")]] == "Neck"
    with pytest.raises(ValidationError, match="Tail"):
        mirror_pairs(sk, {"Tail": "Head"})


def test_mirroring_reflects_positions_and_swaps_sides(database):
    # the humanoid's rest pose is left/right symmetric across x = 0, so mirroring is exact
    plain = MotionDataset(database, length=16, positions=True, contacts=False, dtype=torch.float64)
    flipped = MotionDataset(database, length=16, positions=True, mirror=1.0, dtype=torch.float64)
    sk = humanoid_skeleton()
    pairs = mirror_pairs(sk)
    site_of = {int(j): k for k, j in enumerate(sk.end_site_parents.tolist())}
    points = list(pairs) + [sk.num_joints + site_of[int(pairs[j])] for j in sk.end_site_parents.tolist()]
    a, b = plain[1]["positions"].numpy(), flipped[1]["positions"].numpy()
    want = a[:, points] * np.array([-1.0, 1.0, 1.0])
    np.testing.assert_allclose(b, want, atol=1e-4)  # a's positions are cached as float32
    legs = dict(contacts=True, contact_joints=["LeftLeg", "RightLeg"])
    c0 = MotionDataset(database, length=16, **legs)[torch.tensor(1)]["contacts"]  # a 0-d tensor index too
    c1 = MotionDataset(database, length=16, mirror=1.0, **legs)[1]["contacts"]
    np.testing.assert_array_equal(c1.numpy(), c0.numpy()[:, ::-1])  # the left foot's column is the right's


def test_rotation_about_the_up_axis_turns_the_positions(database):
    # The angle is drawn from (seed, torch.initial_seed()): the torch seed is fixed here, since an earlier test may
    # have left it anywhere, and an angle near zero would not move the points by the margin checked below.
    plain = MotionDataset(database, length=16, positions=True, dtype=torch.float64)
    turned = MotionDataset(database, length=16, positions=True, rotate=180.0, dtype=torch.float64, seed=5)
    with torch.random.fork_rng():
        torch.manual_seed(0)
        a, b = plain[0]["positions"].numpy(), turned[0]["positions"].numpy()
    # some rotation about y: heights kept, horizontal distances from the origin kept, not the identity
    np.testing.assert_allclose(b[..., 1], a[..., 1], atol=1e-4)
    np.testing.assert_allclose(np.hypot(b[..., 0], b[..., 2]), np.hypot(a[..., 0], a[..., 2]), atol=1e-4)
    assert np.abs(b - a).max() > 1.0
    rep = get_representation("root-quat-axis-angle")
    assert turned[0]["features"].shape == (16, rep.width(humanoid_skeleton()))


@pytest.mark.parametrize("shuffle", [True, False])
@pytest.mark.parametrize("drop_last", [False, True])
def test_window_sampler_gives_every_window_once_per_epoch(database, shuffle, drop_last):
    ds = MotionDataset(database, length=4, stride=3)
    sampler = WindowSampler(ds, batch_size=5, shuffle=shuffle, seed=1, drop_last=drop_last)
    epochs = [[i for b in sampler for i in b] for _ in range(2)]
    assert len(list(iter(sampler))) == len(sampler)
    for seen in epochs:
        assert len(seen) == len(set(seen))
        if drop_last:
            assert len(ds) - 5 < len(seen) <= len(ds)
        else:
            assert sorted(seen) == list(range(len(ds)))
    assert (epochs[0] != epochs[1]) == shuffle  # a new permutation each epoch


def test_dataloader_two_workers_each_open_their_own_files(database):
    ds = MotionDataset(database, length=8, stride=4, positions=True)
    ds[0]  # the main process opens the database first: workers must not reuse its HDF5 handle
    loader = torch.utils.data.DataLoader(ds, sampler=WindowSampler(ds, 6, seed=2), batch_size=None,
                                         num_workers=2, multiprocessing_context="fork")
    got = []
    for batch in loader:
        assert batch["features"].shape[1:] == (8, ds.width) and batch["positions"].shape[0] <= 6
        got.extend(zip(batch["clip"].tolist(), batch["start"].tolist()))
    assert sorted(got) == _windows(ds)
    # the standard sampler and collate work too (through __getitems__)
    plain = torch.utils.data.DataLoader(ds, batch_size=7, shuffle=True, num_workers=2)
    got = [w for b in plain for w in zip(b["clip"].tolist(), b["start"].tolist())]
    assert sorted(got) == _windows(ds)


@pytest.mark.slow
def test_dataloader_spawned_workers_get_the_dataset_without_files(database):
    ds = MotionDataset(database, length=8, stride=8)
    ds[0]
    loader = torch.utils.data.DataLoader(ds, sampler=WindowSampler(ds, 4, seed=0), batch_size=None, num_workers=2,
                                         multiprocessing_context="spawn")
    got = [w for b in loader for w in zip(b["clip"].tolist(), b["start"].tolist())]
    assert sorted(got) == _windows(ds)


def test_cache_is_bounded_and_mixed_skeletons(tmp_path):
    clips = {"h": synthetic_motion(frames=30), "c": synthetic_motion(chain_skeleton(5), frames=30)}
    write_database(clips, tmp_path / "mixed.h5")
    with pytest.raises(ValidationError, match="skeletons='group'"):
        same = MotionDataset(tmp_path / "mixed.h5", length=10)
        [same[i] for i in range(len(same))]
    ds = MotionDataset(tmp_path / "mixed.h5", length=10, skeletons="group", cache_bytes=1)
    assert len(ds.group_layouts) == 2
    for batch in WindowSampler(ds, 4, seed=0):
        out = ds[batch]
        assert len(set(ds.group_of[batch].tolist())) == 1 and out["features"].shape[0] == len(batch)
    assert len(ds._cache._entries) == 1  # one clip kept: the bound is bytes, the last clip always stays
    with pytest.raises(ValidationError, match="different feature columns"):
        ds[[0, len(ds) - 1]]


def test_bad_arguments(database):
    with pytest.raises(ValidationError, match="foot, toe or ankle"):  # the humanoid has no foot joint
        MotionDataset(database, length=8, contacts=True)[0]
    with pytest.raises(FormatError, match="nothing-here"):
        MotionDataset("nothing-here.h5")
    with pytest.raises(ValidationError):
        MotionDataset(SHARED_DATA, length=0)


@pytest.mark.realdata
@requires_shared
def test_real_salsa_clips_with_contacts():
    ds = MotionDataset(SHARED_DATA / "cmu" / "beemsoft_salsa" / "60_01_scaled.bvh", representation="dual-quaternion",
                       length=64, stride=64, fps=30.0, contacts=True)
    c = torch.cat([ds[i]["contacts"] for i in range(len(ds))])
    assert c.shape[1] == 2  # lFoot, rFoot
    assert 0.2 < float(c.mean()) < 0.95  # a dancer's feet touch the ground part of the time
