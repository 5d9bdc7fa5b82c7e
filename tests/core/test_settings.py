"""The knob table (core.settings.KNOBS) and what is made from it: BakeSettings and its
validation, the core command line's options, the README's table."""

from __future__ import annotations

import dataclasses
import math

import pytest

from core.cli import parser
from core.settings import (KNOBS, LARGE_SCENE_MONTE_CARLO_RAYS, LARGE_SCENE_SHOOTING, LINE_TOLERANCE, MAX_REFINEMENT,
                           BakeSettings, given_knobs, knob_table, resolved, with_monte_carlo)


def test_bake_settings_has_the_knobs_in_order_with_their_defaults():
    fields = dataclasses.fields(BakeSettings)
    assert [field.name for field in fields] == [knob.name for knob in KNOBS]
    assert all(field.default == knob.default for field, knob in zip(fields, KNOBS))


def bad_values(knob) -> list:
    """Values each rule of ``knob`` must refuse: past its bounds, off its grid, of the wrong kind."""
    if knob.choices:
        return ["nothing", None]
    if knob.type is bool:
        return [2, "yes", None]
    values = [math.nan, math.inf, "ten"] + ([] if knob.none else [None])
    if knob.low is not None:
        values.append(knob.low if knob.open in ("low", "both") else knob.low - 1)
    if knob.high is not None:
        values.append(knob.high if knob.open in ("high", "both") else knob.high + 1)
    if knob.type is int:
        values.append(2.5)
    if knob.square:
        values.append(10)
    if knob.even:
        values.append(63)
    return values


def good_values(knob) -> list:
    """Values inside every rule of ``knob``."""
    if knob.choices:
        return list(knob.choices)
    if knob.type is bool:
        return [True, False]
    values = [knob.default] + ([None] if knob.none else [])
    if knob.square:
        values += [1, 64] + ([0] if knob.low == 0 else [])
    elif knob.high is not None:
        values.append((knob.low + knob.high) / 2 if knob.type is float else knob.high)
    return values


@pytest.mark.parametrize("knob", KNOBS, ids=lambda knob: knob.name)
def test_each_knob_refuses_what_its_rule_excludes_and_takes_the_rest(knob):
    for value in bad_values(knob):
        with pytest.raises(ValueError, match=f"^{knob.name} must be "):
            BakeSettings(**{knob.name: value})
    for value in good_values(knob):
        assert getattr(BakeSettings(**{knob.name: value}), knob.name) == value


def test_resolved_decides_the_automatic_knobs():
    settings = resolved(BakeSettings(), extent=8.0)
    assert settings.patch_size == 1.0 and settings.monte_carlo_rays is None
    assert resolved(BakeSettings(patch_size=0.5), 8.0).patch_size == 0.5
    # Monte Carlo from LARGE_SCENE_SHOOTING form factors per round of shots, P (P + N), on
    patches = 1_000

    def line_at(settings, line: float) -> bool:
        """Whether ``settings`` on a scene of extent 8 shoot just below ``line`` and go by Monte Carlo at it."""
        nodes = -(-int(line) // patches) - patches
        return (with_monte_carlo(settings, patches, nodes - 1, 8.0).monte_carlo_rays == 0
                and with_monte_carlo(settings, patches, nodes, 8.0).monte_carlo_rays == LARGE_SCENE_MONTE_CARLO_RAYS)

    assert line_at(settings, LARGE_SCENE_SHOOTING)
    assert with_monte_carlo(BakeSettings(monte_carlo_rays=16), patches, 10**5, 8.0).monte_carlo_rays == 16
    assert with_monte_carlo(BakeSettings(monte_carlo_rays=0), 10**5, 10**5, 8.0).monte_carlo_rays == 0
    # finer patches than the default move the line up with the square of their refinement, up to
    # MAX_REFINEMENT times; coarser ones leave it
    assert line_at(resolved(BakeSettings(patch_size=1 / 1.5), 8.0), 1.5**2 * LARGE_SCENE_SHOOTING)
    assert line_at(resolved(BakeSettings(patch_size=0.1), 8.0), MAX_REFINEMENT * LARGE_SCENE_SHOOTING)
    assert line_at(resolved(BakeSettings(patch_size=2.0), 8.0), LARGE_SCENE_SHOOTING)
    # a tighter tolerance than LINE_TOLERANCE moves it up with it (the Reference preset's 1e-4: ten times as
    # far), whichever is more; a looser one leaves it
    assert line_at(resolved(BakeSettings(tolerance=LINE_TOLERANCE / 10), 8.0), 10 * LARGE_SCENE_SHOOTING)
    assert line_at(resolved(BakeSettings(tolerance=LINE_TOLERANCE / 10, patch_size=0.5), 8.0),
                   10 * LARGE_SCENE_SHOOTING)
    assert line_at(resolved(BakeSettings(tolerance=LINE_TOLERANCE * 10), 8.0), LARGE_SCENE_SHOOTING)


def test_the_command_line_offers_every_exposed_knob_by_its_name():
    command = parser()._subparsers._group_actions[0].choices["bake"]
    options = {flag for action in command._actions for flag in action.option_strings}
    exposed = [knob for knob in KNOBS if knob.exposed]
    assert {knob.flag for knob in exposed} <= options
    assert not any(knob.flag in options for knob in KNOBS if not knob.exposed)
    arguments = command.parse_args(["scene.obj", "--patch-size", "auto", "--max-shots", "none", "--monte-carlo-rays",
                                    "16", "--no-merge-flat", "--rays-per-form-factor", "4", "--method", "hemicube"])
    assert given_knobs(arguments) == {"patch_size": None, "max_shots": None, "monte_carlo_rays": 16,
                                      "merge_flat": False, "rays_per_form_factor": 4, "method": "hemicube"}
    assert given_knobs(command.parse_args(["scene.obj"])) == {}


def test_the_knob_table_has_a_row_per_knob():
    rows = knob_table().splitlines()[2:]
    assert [row.split("`")[1] for row in rows] == [knob.name for knob in KNOBS]
