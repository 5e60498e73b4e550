"""Outage scenarios: the paper's presets, window placement and the random dropout generator."""
from __future__ import annotations

import numpy as np
import pytest

from graphnav.core.errors import ConfigError
from graphnav.core.scenarios import (
    SCENARIOS,
    Outage,
    markov_dropout,
    scenario_outage,
    window_starts,
)


def test_presets_are_the_papers_cases():
    # paper beams 1..4 -> indices 0..3: "2-missing" loses beams 1 and 3, "3-missing" keeps only beam 2
    assert scenario_outage("2-missing", 10.0).missing == (0, 2)
    assert scenario_outage("3-missing", 10.0).missing == (0, 2, 3)
    assert scenario_outage("none", 10.0).missing == ()
    assert set(SCENARIOS) == {"none", "2-missing", "3-missing", "0-beams", "markov"}
    with pytest.raises(ConfigError, match="unknown scenario"):
        scenario_outage("4-missing", 0.0)


def test_outage_mask_is_half_open_window():
    outage = scenario_outage("3-missing", start_s=5.0, duration_s=3.0)
    assert outage.end_s == 8.0
    t = np.array([4.9, 5.0, 7.99, 8.0])
    mask = outage.mask(t)
    assert mask.tolist() == [[False] * 4, [True, False, True, True], [True, False, True, True], [False] * 4]


def test_outage_rejects_bad_specs():
    with pytest.raises(ConfigError):
        Outage(0.0, -1.0, (0,))
    with pytest.raises(ConfigError):
        Outage(0.0, 1.0, (4,))


def test_window_starts_respect_settle_gap_and_end():
    starts = window_starts(0.0, 400.0, window_s=30.0, settle_s=60.0, gap_s=60.0)
    assert starts[0] == 60.0
    assert np.all(np.diff(starts) >= 30.0 + 60.0)
    assert starts[-1] + 30.0 <= 400.0 - 5.0
    assert starts == [60.0, 150.0, 240.0, 330.0]
    thinned = window_starts(0.0, 4000.0, max_windows=5)
    assert len(thinned) == 5 and thinned[0] == 60.0 and thinned == sorted(thinned)
    assert window_starts(0.0, 80.0) == []          # too short for a window after settling


def test_markov_dropout_statistics():
    p_drop, p_recover = 0.05, 0.3
    valid = markov_dropout(200_000, p_drop, p_recover, seed=1)
    assert valid.shape == (200_000, 4) and valid.dtype == bool
    # stationary availability p_recover / (p_drop + p_recover) = 0.857
    np.testing.assert_allclose(valid.mean(axis=0), p_recover / (p_drop + p_recover), atol=0.01)
    # transition frequencies match the chain's probabilities
    prev, nxt = valid[:-1], valid[1:]
    drop_rate = np.sum(prev & ~nxt) / np.sum(prev)
    recover_rate = np.sum(~prev & nxt) / np.sum(~prev)
    assert drop_rate == pytest.approx(p_drop, rel=0.05)
    assert recover_rate == pytest.approx(p_recover, rel=0.05)
    # beams drop independently: P(two beams out together) ~ product of the marginals
    out = ~valid
    assert np.mean(out[:, 0] & out[:, 1]) == pytest.approx(out[:, 0].mean() * out[:, 1].mean(), rel=0.1)


def test_markov_dropout_is_seeded():
    np.testing.assert_array_equal(markov_dropout(500, seed=3), markov_dropout(500, seed=3))
    assert not np.array_equal(markov_dropout(500, seed=3), markov_dropout(500, seed=4))
    assert markov_dropout(1000, p_drop=0.0, p_recover=1.0, seed=0).all()


def test_total_outage_and_markov_scenarios():
    from graphnav.core.scenarios import is_total_outage
    t = np.arange(0.0, 100.0, 0.2)
    total = scenario_outage("0-beams", 10.0, 60.0)
    assert is_total_outage("0-beams") and not is_total_outage("3-missing")
    inside = (t >= 10.0) & (t < 70.0)
    assert total.mask(t)[inside].all() and not total.mask(t)[~inside].any()
    markov = scenario_outage("markov", 10.0, 60.0)
    mask = markov.mask(t)
    assert not mask[~inside].any()
    # random dropouts: some but not all beams missing inside, bursts, and the same pattern every time
    frac = mask[inside].mean()
    assert 0.15 < frac < 0.6
    assert np.array_equal(mask, scenario_outage("markov", 10.0, 60.0).mask(t))
    assert not np.array_equal(mask[inside], scenario_outage("markov", 11.0, 60.0).mask(t + 1.0)[inside])
    with pytest.raises(ConfigError):
        Outage(0.0, 1.0, (0,), markov=(0.0, 0.5))
