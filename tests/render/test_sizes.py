"""The largest pictures `exhibit render` draws: the GL context's own limits (its largest side,
and the largest texture a frame needs: the intersection curves' float buffer, once per MSAA
sample) are checked before drawing, so a size the driver would refuse is one line, exit 2,
instead of "framebuffer not complete" with a traceback (issue 33)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
from PIL import Image

from exhibit.render.offscreen import MAX_TEXTURE_BYTES, size_limits, size_problem


def fake_ctx(side: int = 16384, viewport: int = 16384, samples: int = 4):
    info = {
        "GL_MAX_TEXTURE_SIZE": side,
        "GL_MAX_RENDERBUFFER_SIZE": side,
        "GL_MAX_VIEWPORT_DIMS": (viewport, viewport),
    }
    return SimpleNamespace(info=info, max_samples=samples)


def test_the_limits_are_the_least_of_the_gl_ones():
    assert size_limits(fake_ctx(16384, 8192)) == (8192, 4)
    assert size_limits(SimpleNamespace(info={}, max_samples=0)) == (4096, 0)


def test_the_documented_largest_size_fits_without_msaa():
    assert size_problem(fake_ctx(), (8192, 8192)) is None
    assert MAX_TEXTURE_BYTES >= 8192 * 8192 * 16


@pytest.mark.parametrize(
    "ctx, size, samples, words",
    [
        (fake_ctx(), (8192, 8192), 4, "with 4 samples needs a 4.0 GiB buffer"),
        (fake_ctx(), (8193, 8192), 0, "over the 1 GiB"),
        (fake_ctx(side=4096), (4097, 16), 0, "at most 4096 pixels a side"),
        (fake_ctx(viewport=2048), (16, 2049), 0, "at most 2048 pixels a side"),
    ],
)
def test_sizes_beyond_the_context_are_named(ctx, size, samples, words):
    problem = size_problem(ctx, size, samples)
    assert problem is not None and words in problem


def test_the_context_s_own_limits(gl):
    side, _ = size_limits(gl.ctx)
    assert side >= 8192  # llvmpipe and every GPU the kiosk runs on
    assert size_problem(gl.ctx, (1280, 720), 4) is None


def test_a_still_too_large_for_msaa_is_one_line(cli, tmp_path):
    """8192 x 8192 with 4x MSAA needs a 4 GiB texture: llvmpipe's framebuffer is incomplete
    (was: internal error, INCOMPLETE_ATTACHMENT)."""
    result = cli(
        "render", "hopf", "--resolution", "12", "--size", "8192x8192",
        "--out", str(tmp_path / "big.png"),
    )  # fmt: skip
    assert result.returncode == 2, result.stderr
    assert result.stderr.count("\n") == 1 and "--size: 8192x8192 with 4 samples" in result.stderr
    assert not (tmp_path / "big.png").exists()


@pytest.mark.slow
def test_the_takeover_at_the_documented_largest_size(cli, tmp_path, monkeypatch):
    """The issue's case: 8192 x 8192 is drawn (about 30 s and 3 GB on llvmpipe)."""
    monkeypatch.setenv("EXHIBIT_CACHE_DIR", str(tmp_path / "cache"))
    site = tmp_path / "site.toml"
    site.write_text("[content]\nresolution = { hopf = 12 }\n")
    out = tmp_path / "b.png"
    result = cli(
        "render", "--takeover", "hopf", "--config", str(site), "--size", "8192x8192",
        "--after", "0", "--out", str(out),
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    with Image.open(out) as image:
        assert image.size == (8192, 8192)
