"""Uniform names are checked against the shaders' sources: a typo on the Python side is an error
under tests and is logged once in a kiosk, while a declared uniform the compiler dropped is
skipped, as it must be."""

from __future__ import annotations

import logging

import pytest

from exhibit.geometry.pipeline import clip_transform
from exhibit.geometry.view import ViewState
from exhibit.render import shaders
from exhibit.render.passes.shared import pipeline_uniforms


def test_declared_uniforms_read_the_source_with_its_includes():
    surface = shaders.declared_uniforms("surface.glsl")
    assert {"u_M", "u_plane_d1", "u_r1", "u_viewport"} <= surface  # from pipeline.glsl
    # the lights are lighting.glsl's, and reach the surface program through its include
    assert "u_lights" in shaders.declared_uniforms("lighting.glsl")
    assert "u_lights" in surface
    assert not any(" " in name or "[" in name for name in surface)


def test_every_pipeline_value_is_declared_in_pipeline_glsl():
    view = ViewState()
    values = pipeline_uniforms(clip_transform(view, 16 / 9), view, (1600, 900))
    assert set(values) <= shaders.declared_uniforms("pipeline.glsl")


def test_a_typo_is_an_error_in_tests(gl):
    prog = gl.renderer.programs["background"]
    shaders.set_uniforms(prog, {"u_top": (0.1, 0.2, 0.3)})
    with pytest.raises(shaders.UniformError, match=r"background.glsl: no uniform 'u_topp'"):
        shaders.set_uniforms(prog, {"u_topp": (0.1, 0.2, 0.3)})


def test_in_a_kiosk_a_typo_is_logged_once_and_drawing_goes_on(gl, monkeypatch, caplog):
    monkeypatch.delenv(shaders.STRICT_ENV, raising=False)
    monkeypatch.setattr(shaders, "_reported", set())
    prog = gl.renderer.programs["background"]
    with caplog.at_level(logging.ERROR, logger="exhibit.render.shaders"):
        for _ in range(3):
            shaders.set_uniforms(prog, {"u_bottm": (0.0, 0.0, 0.0), "u_top": (0.5, 0.5, 0.5)})
    assert [r.getMessage() for r in caplog.records].count(
        caplog.records[0].getMessage()
    ) == 1 and "u_bottm" in caplog.text
    assert prog["u_top"].value == pytest.approx((0.5, 0.5, 0.5))


def test_a_declared_uniform_the_compiler_dropped_is_skipped(gl):
    """The depth-only surface variant declares u_color (surface.glsl) but never uses it."""
    prog = gl.renderer.programs["surface_depth"]
    assert "u_color" in prog.extra["uniforms"] and "u_color" not in prog
    shaders.set_uniforms(prog, {"u_color": (1.0, 0.0, 0.0)})  # no error, nothing to set
