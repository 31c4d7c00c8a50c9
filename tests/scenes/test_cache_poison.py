"""A poisoned mesh cache never takes the kiosk down: every kind of bad entry (malformed manifest,
wrong shapes or types, out-of-range indices, NaN or huge values, zip bombs, FIFOs, symlinks,
folders, truncated or random bytes) is refused with a warning, rebuilt, and replaced by the
rebuilt mesh, without hanging; and writes never follow a planted symlink or leave debris."""

from __future__ import annotations

import io
import json
import logging
import os
import threading
import time
import zipfile

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exhibit import scenes
from exhibit.schema import files
from exhibit.scenes import cache
from exhibit.scenes.cache import build_cached
from exhibit.surfaces import mesh as meshmod
from exhibit.surfaces.mesh import Mesh4D
from tests.hypothesis_profiles import examples

SCENE = scenes.get("hopf")
RES = 8
REFERENCE = SCENE.build(None, RES)
VALID = REFERENCE.to_bytes()
COUNTS: dict[str, int] = {}  # hypothesis examples run per test, printed with -s


def within(seconds, fn, *args):
    """fn(*args) in a thread; fails instead of hanging when it does not return in time."""
    box = {}
    thread = threading.Thread(target=lambda: box.update(value=fn(*args)), daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"{fn.__name__} still running after {seconds} s"
    return box["value"]


def assert_same(a: Mesh4D, b: Mesh4D) -> None:
    assert [s.name for s in a.surfaces] == [s.name for s in b.surfaces]
    for x, y in zip(a.surfaces, b.surfaces):
        for attr in ("positions", "normals", "triangles", "singular"):
            np.testing.assert_array_equal(getattr(x, attr), getattr(y, attr))
        assert x.material == y.material
        assert {**x.info, "seconds": 0} == {**y.info, "seconds": 0}  # build time varies
    assert [(c.name, c.material, c.closed) for c in a.curves] == [
        (c.name, c.material, c.closed) for c in b.curves
    ]
    for x, y in zip(a.curves, b.curves):
        np.testing.assert_array_equal(x.points, y.points)
    assert [(m.name, m.label, list(m.position)) for m in a.markers] == [
        (m.name, m.label, list(m.position)) for m in b.markers
    ]


def unpack(data: bytes = VALID) -> tuple[dict, dict]:
    with np.load(io.BytesIO(data)) as archive:
        arrays = {k: archive[k].copy() for k in archive.files}
    return arrays, json.loads(arrays["manifest"].tobytes())


def pack(arrays: dict, manifest=None) -> bytes:
    arrays = dict(arrays)
    if manifest is not None:
        raw = manifest if isinstance(manifest, bytes) else json.dumps(manifest).encode()
        arrays["manifest"] = np.frombuffer(raw, dtype=np.uint8)
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **arrays)
    return buffer.getvalue()


def poisoned(change) -> bytes:
    """The valid archive with change(arrays, manifest) applied (it may return a new manifest)."""
    arrays, manifest = unpack()
    manifest = change(arrays, manifest) or manifest
    return pack(arrays, manifest)


@pytest.fixture
def entry(tmp_path):
    """The cache file of SCENE after a first build (path; the mesh is REFERENCE)."""
    build_cached(SCENE, None, RES, tmp_path)
    (path,) = tmp_path.glob("hopf-*.npz")
    return path


def rebuilt(entry, caplog, reason: str = "", replaced: bool = True) -> None:
    """build_cached with the poisoned entry: a warning naming it, the right mesh, no hang; then
    (replaced) the entry is a valid regular file again and the next build is a hit."""
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="exhibit.scenes.cache"):
        mesh, hit = within(20, build_cached, SCENE, None, RES, entry.parent)
    assert not hit
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert any(str(entry) in w and "unusable" in w and reason in w for w in warnings), warnings
    assert_same(mesh, REFERENCE)
    if replaced:
        assert entry.is_file() and not entry.is_symlink()
        assert build_cached(SCENE, None, RES, entry.parent)[1]
    assert not list(entry.parent.glob("*.tmp"))


# ---------------------------------------------------------------------- the manifest


def set_manifest(value):
    raw = value if isinstance(value, bytes) else json.dumps(value).encode()
    return lambda arrays, manifest: raw


def edit(fn):
    def change(arrays, manifest):
        fn(manifest)
        return manifest

    return change


MANIFEST_POISONS = {
    "empty list": set_manifest([]),
    "string": set_manifest("mesh"),
    "null": set_manifest(None),
    "number": set_manifest(1),
    "not utf-8": set_manifest(b"\xff\xfe{"),
    "not json": set_manifest(b'{"format": 1,'),
    "deeply nested": set_manifest(b"[" * 100_000 + b"]" * 100_000),
    "format 2": edit(lambda m: m.update(format=2)),
    "surfaces a dict": edit(lambda m: m.update(surfaces={})),
    "surfaces missing": edit(lambda m: m.pop("surfaces")),
    "part not a dict": edit(lambda m: m["curves"].__setitem__(0, "curve")),
    "name a number": edit(lambda m: m["surfaces"][0].update(name=7)),
    "info a list": edit(lambda m: m["surfaces"][0].update(info=[])),
    "closed a string": edit(lambda m: m["curves"][0].update(closed="yes")),
    "material missing": edit(lambda m: m["surfaces"][0].pop("material")),
    "material extra key": edit(lambda m: m["surfaces"][0]["material"].update(shader="x")),
    "colour NaN": edit(lambda m: m["surfaces"][0]["material"].update(color=[float("nan")] * 3)),
    "colour out of range": edit(lambda m: m["curves"][0]["material"].update(color=[2, 0, 0])),
    "colour huge int": edit(lambda m: m["curves"][0]["material"].update(color=[10**400, 0, 0])),
    "colour bool": edit(lambda m: m["curves"][0]["material"].update(color=[True, 0, 0])),
    "line width 1e308": edit(lambda m: m["curves"][0]["material"].update(line_width=1e308)),
    "line width inf": edit(lambda m: m["curves"][0]["material"].update(line_width=float("inf"))),
    "style a list": edit(lambda m: m["curves"][0]["material"].update(style=["solid"])),
    "more parts than arrays": edit(lambda m: m["surfaces"].append(m["surfaces"][0])),
    "fewer parts than arrays": edit(lambda m: m["curves"].pop()),
}


@pytest.mark.parametrize("name", MANIFEST_POISONS)
def test_malformed_manifest_is_rebuilt(entry, caplog, name):
    entry.write_bytes(poisoned(MANIFEST_POISONS[name]))
    rebuilt(entry, caplog)


# ---------------------------------------------------------------------- the arrays


def arr(key, fn):
    def change(arrays, manifest):
        arrays[key] = fn(arrays[key])

    return change


def add_marker(position):
    def change(arrays, manifest):
        manifest["markers"].append(
            {
                "name": "m",
                "label": "",
                "material": {"color": [1, 1, 0], "style": "solid", "line_width": 2.0},
            }
        )
        arrays["m0_position"] = np.asarray(position, dtype=np.float64)
        return manifest

    return change


def with_value(value, index=(0, 0)):
    def fn(a):
        a = a.copy()
        a[index] = value
        return a

    return fn


ARRAY_POISONS = {
    # shapes and types
    "positions (n, 3)": arr("s0_positions", lambda a: a[:, :3].copy()),
    "positions flat": arr("s0_positions", lambda a: a.reshape(-1)),
    "positions float32": arr("s0_positions", lambda a: a.astype(np.float32)),
    "positions big-endian": arr("s0_positions", lambda a: a.astype(">f8")),
    "positions Fortran order": arr("s0_positions", lambda a: np.asfortranarray(a)),
    "positions as objects": arr("s0_positions", lambda a: a.astype(object)),
    "normals (n, 4)": arr("s0_normals", lambda a: a[:, 0].copy()),
    "one normal pair short": arr("s0_normals", lambda a: a[1:].copy()),
    "triangles float": arr("s0_triangles", lambda a: a.astype(np.float64)),
    "triangles int64": arr("s0_triangles", lambda a: a.astype(np.int64)),
    "triangles (m, 4)": arr("s0_triangles", lambda a: np.hstack([a, a[:, :1]])),
    "singular one short": arr("s0_singular", lambda a: a[1:].copy()),
    "singular as int": arr("s0_singular", lambda a: a.astype(np.int8)),
    "curve points (k, 2)": arr("c0_points", lambda a: a[:, :2].copy()),
    "marker position (3,)": add_marker([0.0, 0.0, 0.0]),
    "array missing": lambda arrays, manifest: arrays.__delitem__("s1_normals"),
    "extra array": lambda arrays, manifest: arrays.update(extra=np.zeros(3)),
    # indices
    "triangle index = n": arr("s0_triangles", lambda a: _set_index(a, "n")),
    "triangle index -1": arr("s0_triangles", lambda a: _set_index(a, -1)),
    "triangle index 2**31-1": arr("s0_triangles", lambda a: _set_index(a, 2**31 - 1)),
    # values
    "position NaN": arr("s0_positions", with_value(np.nan)),
    "position inf": arr("s1_positions", with_value(np.inf, (3, 2))),
    "position 1e308": arr("s2_positions", with_value(1e308)),
    "position -1e7": arr("s0_positions", with_value(-1e7)),
    "normal NaN": arr("s0_normals", with_value(np.nan, (0, 1, 3))),
    "normal 1e308": arr("s0_normals", with_value(1e308, (2, 0, 0))),
    "curve point 1e308": arr("c3_points", with_value(1e308)),
    "curve point NaN": arr("c0_points", with_value(np.nan, (-1, 3))),
    "marker position NaN": add_marker([np.nan, 0.0, 0.0, 0.0]),
    "marker position -inf": add_marker([0.0, -np.inf, 0.0, 0.0]),
}


def _set_index(triangles, value):
    triangles = triangles.copy()
    triangles[-1, 2] = REFERENCE.surfaces[0].positions.shape[0] if value == "n" else value
    return triangles


@pytest.mark.parametrize("name", ARRAY_POISONS)
def test_bad_arrays_are_rebuilt(entry, caplog, name):
    entry.write_bytes(poisoned(ARRAY_POISONS[name]))
    rebuilt(entry, caplog)


def test_a_valid_marker_still_loads():
    """The checks refuse only what is wrong: the same edit with a good marker is accepted."""
    mesh = Mesh4D.from_bytes(poisoned(add_marker([0.5, 0.0, -1.0, 2.0])))
    assert list(mesh.markers[0].position) == [0.5, 0.0, -1.0, 2.0]


# ---------------------------------------------------------------------- the zip container


def zip_bytes(members: dict[str, bytes], compression=zipfile.ZIP_DEFLATED) -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w", compression) as z:
        for name, data in members.items():
            z.writestr(name, data)
    return buffer.getvalue()


def members(data: bytes = VALID) -> dict[str, bytes]:
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        return {name: z.read(name) for name in z.namelist()}


def npy(array) -> bytes:
    buffer = io.BytesIO()
    np.save(buffer, array)
    return buffer.getvalue()


def test_zip_bomb_is_refused_without_inflating(entry, caplog, monkeypatch):
    """64 MiB of zeros (64 KiB compressed) against a cap lowered to 16 MiB: refused from the
    directory's sizes; the bomb is never opened."""
    monkeypatch.setattr(meshmod, "MAX_UNPACKED_BYTES", 16 << 20)
    bomb = members()
    bomb["s0_positions.npy"] = npy(np.zeros(((64 << 20) // 32, 4)))
    data = zip_bytes(bomb)
    assert len(data) < 1 << 20
    opened = []
    real_open = zipfile.ZipFile.open
    monkeypatch.setattr(
        zipfile.ZipFile,
        "open",
        lambda self, name, *a, **k: (
            opened.append(getattr(name, "filename", name)) or real_open(self, name, *a, **k)
        ),
    )
    with pytest.raises(ValueError, match="more than the 16777216 allowed"):
        Mesh4D.from_bytes(data)
    assert opened == []
    entry.write_bytes(data)
    rebuilt(entry, caplog, "more than the 16777216 allowed")


def patch_sizes(data: bytes, name: bytes, size: int) -> bytes:
    """``data`` with member ``name``'s uncompressed size rewritten in both its headers."""
    out = bytearray(data)
    for sig, offset, name_at in ((b"PK\x03\x04", 22, 30), (b"PK\x01\x02", 24, 46)):
        start = 0
        while (start := out.find(sig, start)) >= 0:
            if out[start + name_at : start + name_at + len(name)] == name:
                out[start + offset : start + offset + 4] = size.to_bytes(4, "little")
            start += 4
    return bytes(out)


def test_declared_size_over_the_default_cap_is_refused(entry, caplog):
    """A member claiming 4 GiB - 1 (a bomb that would inflate to it) meets the real 1 GiB cap."""
    data = patch_sizes(zip_bytes(members()), b"s0_positions.npy", 0xFFFF_FFFF)
    entry.write_bytes(data)
    rebuilt(entry, caplog, "allowed")


def test_member_shorter_than_its_header_claims_is_refused(entry, caplog):
    """The .npy header claims 10**12 rows; nothing that size is allocated."""
    buffer = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        buffer, {"descr": "<f8", "fortran_order": False, "shape": (10**12, 4)}
    )
    entry.write_bytes(zip_bytes({**members(), "s0_positions.npy": buffer.getvalue() + bytes(32)}))
    rebuilt(entry, caplog, "smaller member")


@pytest.mark.parametrize("method", [zipfile.ZIP_BZIP2, zipfile.ZIP_LZMA])
def test_unbounded_compression_methods_are_refused(entry, caplog, method):
    """bz2 and lzma inflate without an output limit in zipfile: refused outright."""
    entry.write_bytes(zip_bytes(members(), method))
    rebuilt(entry, caplog, "compression method")


def test_stored_members_are_accepted():
    assert_same(Mesh4D.from_bytes(zip_bytes(members(), zipfile.ZIP_STORED)), REFERENCE)


@pytest.mark.parametrize(
    "name, data",
    [
        ("duplicate member", lambda: _duplicate()),
        ("non-npy member", lambda: zip_bytes({**members(), "notes.txt": b"hi"})),
        (
            "many tiny members",
            lambda: zip_bytes({f"{i}.npy": b"" for i in range(25_000)}, zipfile.ZIP_STORED),
        ),
        (
            "npy version 9",
            lambda: zip_bytes(
                {**members(), "manifest.npy": b"\x93NUMPY\x09\x00" + members()["manifest.npy"][8:]}
            ),
        ),
        ("empty file", lambda: b""),
        ("random bytes", lambda: np.random.default_rng(1).bytes(5000)),
        ("half the archive", lambda: VALID[: len(VALID) // 2]),
        ("all but the last byte", lambda: VALID[:-1]),
        ("zip64 directory", lambda: _zip64()),
    ],
)
def test_bad_containers_are_rebuilt(entry, caplog, name, data):
    entry.write_bytes(data())
    rebuilt(entry, caplog)


def _duplicate() -> bytes:
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as z, pytest.warns(UserWarning, match="Duplicate"):
        for member, data in members().items():
            z.writestr(member, data)
        z.writestr("manifest.npy", members()["manifest.npy"])
    return buffer.getvalue()


def _zip64() -> bytes:
    """The valid archive written with a zip64 end record, as zipfile does past 65,535 members."""
    real, zipfile.ZIP_FILECOUNT_LIMIT = zipfile.ZIP_FILECOUNT_LIMIT, 1
    try:
        return zip_bytes(members())
    finally:
        zipfile.ZIP_FILECOUNT_LIMIT = real


# ---------------------------------------------------------------------- what is at the path


def test_fifo_is_refused_without_hanging(entry, caplog):
    entry.unlink()
    os.mkfifo(entry)
    rebuilt(entry, caplog, "not a regular file")


def test_symlink_to_dev_zero_is_refused(entry, caplog):
    entry.unlink()
    entry.symlink_to("/dev/zero")
    rebuilt(entry, caplog, "symbolic link")


def test_symlink_to_a_valid_mesh_elsewhere_is_refused_and_not_written_through(
    entry, caplog, tmp_path_factory
):
    """os.replace renames over the link itself: the file it pointed to is untouched."""
    outside = tmp_path_factory.mktemp("outside") / "target.npz"
    outside.write_bytes(VALID)
    outside.chmod(0o600)
    entry.unlink()
    entry.symlink_to(outside)
    rebuilt(entry, caplog, "symbolic link")
    assert outside.read_bytes() == VALID and (outside.stat().st_mode & 0o777) == 0o600


def test_dangling_symlink_is_replaced(entry, caplog):
    entry.unlink()
    entry.symlink_to(entry.parent / "nowhere")
    rebuilt(entry, caplog, "symbolic link")
    assert not (entry.parent / "nowhere").exists()


def test_empty_folder_in_place_of_the_file_is_replaced(entry, caplog):
    entry.unlink()
    entry.mkdir()
    rebuilt(entry, caplog, "not a regular file")


def test_full_folder_in_place_of_the_file_is_left_and_only_costs_the_rebuild(entry, caplog):
    entry.unlink()
    entry.mkdir()
    (entry / "keep").write_text("someone's")
    rebuilt(entry, caplog, "not a regular file", replaced=False)
    assert (entry / "keep").read_text() == "someone's"
    assert any("could not write" in r.getMessage() for r in caplog.records)


def test_file_over_the_size_cap_is_refused_unread(entry, caplog, monkeypatch):
    monkeypatch.setattr(cache, "MAX_CACHE_BYTES", entry.stat().st_size - 1)
    monkeypatch.setattr(meshmod.Mesh4D, "to_bytes", lambda self: b"x")  # fits the lowered cap
    reads = []
    real_read = os.read
    me = threading.get_ident()  # os.read is global: another test's threads may still read

    def read(fd, n):
        if threading.get_ident() == me:
            reads.append(n)
        return real_read(fd, n)

    monkeypatch.setattr(cache.os, "read", read)
    caplog.set_level(logging.WARNING)
    mesh, hit = build_cached(SCENE, None, RES, entry.parent)
    assert not hit and not reads and entry.read_bytes() == b"x"
    assert "-byte limit" in caplog.text and str(entry) in caplog.text


# ---------------------------------------------------------------------- random corruption


@settings(max_examples=examples(400), deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, len(VALID) - 1), st.integers(0, 255)), min_size=1, max_size=8)
)
def test_random_byte_corruption_is_refused_or_harmless(edits):
    """Replace up to 8 bytes anywhere: the archive is refused (ValueError) or, where the bytes
    were ones nothing reads (timestamps, attributes), loads as exactly the original mesh: the
    members' CRC-32s catch every change to the data."""
    COUNTS["corruptions"] = COUNTS.get("corruptions", 0) + 1
    data = bytearray(VALID)
    for at, value in edits:
        data[at] = value
    try:
        mesh = Mesh4D.from_bytes(bytes(data))
    except ValueError:
        COUNTS["corruptions refused"] = COUNTS.get("corruptions refused", 0) + 1
        return
    assert_same(mesh, REFERENCE)


@settings(max_examples=examples(150), deadline=None)
@given(st.integers(0, len(VALID) - 1))
def test_every_truncation_is_refused(cut):
    COUNTS["truncations"] = COUNTS.get("truncations", 0) + 1
    with pytest.raises(ValueError, match="not a mesh archive"):
        Mesh4D.from_bytes(VALID[:cut])


@settings(
    max_examples=examples(60),
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(st.integers(0, len(VALID) - 1), st.binary(min_size=1, max_size=64))
def test_corrupt_entries_through_build_cached(tmp_path, at, junk):
    """End to end: a corrupted file on disk never raises and always yields the right mesh."""
    COUNTS["end-to-end corruptions"] = COUNTS.get("end-to-end corruptions", 0) + 1
    folder = tmp_path / f"c{COUNTS['end-to-end corruptions']}"
    build_cached(SCENE, None, RES, folder)
    (path,) = folder.glob("hopf-*.npz")
    path.write_bytes(VALID[:at] + junk + VALID[at + len(junk) :])
    logging.disable(logging.WARNING)
    try:
        mesh, _ = build_cached(SCENE, None, RES, folder)
    finally:
        logging.disable(logging.NOTSET)
    assert_same(mesh, REFERENCE)
    assert build_cached(SCENE, None, RES, folder)[1]


def test_report_example_counts(capsys):
    """Runs last in this file: prints how many examples each hypothesis test ran (pytest -s)."""
    with capsys.disabled():
        print("\nhypothesis examples:", COUNTS)


# ---------------------------------------------------------------------- writing


def key_name() -> str:
    return f"hopf-{cache.cache_key(SCENE, SCENE.resolve(None), RES)}.npz"


def test_write_never_follows_a_symlink_at_the_temporary_name(tmp_path, caplog, monkeypatch):
    """Even with the random part of the name guessed, O_EXCL|O_NOFOLLOW refuses the planted
    link: the write is skipped with a warning and the link's target is untouched."""
    monkeypatch.setattr(files.secrets, "token_hex", lambda n: "0" * (2 * n))
    victim = tmp_path / "victim"
    victim.write_text("precious")
    victim.chmod(0o600)
    folder = tmp_path / "cache"
    folder.mkdir()
    for digits in range(8, 33, 2):  # whatever length the writer's random part has
        (folder / f".{key_name()}.{'0' * digits}.tmp").symlink_to(victim)
    caplog.set_level(logging.WARNING)
    mesh, hit = build_cached(SCENE, None, RES, folder)
    assert not hit and len(mesh.surfaces) == 3 and "could not write" in caplog.text
    assert victim.read_text() == "precious" and (victim.stat().st_mode & 0o777) == 0o600
    assert not (folder / key_name()).exists()


def test_temporary_names_are_unpredictable(tmp_path, monkeypatch):
    names = []
    real_open = os.open
    monkeypatch.setattr(
        cache.os,
        "open",
        lambda p, flags, *a, **k: (names.append(str(p)), real_open(p, flags, *a, **k))[1],
    )
    for i in range(3):
        build_cached(SCENE, None, RES, tmp_path / str(i))
    tmps = {os.path.basename(n) for n in names if n.endswith(".tmp")}
    assert len(tmps) == 3


@pytest.mark.parametrize("failing", ["write", "fsync", "replace"])
def test_a_failed_write_leaves_no_temporary_file(tmp_path, caplog, monkeypatch, failing):
    def boom(*args, **kwargs):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(cache.os, failing, boom)
    caplog.set_level(logging.WARNING)
    mesh, hit = build_cached(SCENE, None, RES, tmp_path)
    assert not hit and len(mesh.surfaces) == 3
    assert "No space left on device" in caplog.text
    assert list(tmp_path.iterdir()) == []


def test_stale_temporary_files_are_swept_at_write_time(tmp_path):
    old = time.time() - 2 * cache.STALE_TMP_S
    stale, fresh = tmp_path / ".x.npz.ab.tmp", tmp_path / ".y.npz.cd.tmp"
    folder = tmp_path / "d.tmp"
    for path in (stale, fresh):
        path.write_bytes(b"half a mesh")
    folder.mkdir()
    link = tmp_path / "l.tmp"
    link.symlink_to(tmp_path / "elsewhere")
    for path in (stale, folder, link):
        os.utime(path, (old, old), follow_symlinks=False)
    build_cached(SCENE, None, RES, tmp_path)
    assert not stale.exists() and not link.is_symlink()
    assert fresh.exists() and folder.is_dir()
