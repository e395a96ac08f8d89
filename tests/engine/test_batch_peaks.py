"""Closed-loop peaks of many loops of one structure at once (issue 53, section 1): the batched
grid-free peak search (`engine.margins.pole_zero.batch_peaks`) against the per-loop path
(`engine.margins.peaks.refined_peaks` on each sample's own loop model, built from the network),
Ms, Mt and the disk margin's |S - 1/2| over the whole axis and over a band, equal to 1e-12
relative on every certified sample; 158 of 160 certified."""

from __future__ import annotations

import math

import numpy as np
import pytest

from engine.analysis import unity_feedback
from engine.loop.batch_forms import batch_pole_zero
from engine.loop.responses import loop_model
from engine.margins.disk import disk_transform
from engine.margins.peaks import complementary, refined_peaks, sensitivity
from engine.margins.pole_zero.batch_peaks import batch_moebius_peaks
from engine.margins.search import Band
from tests.engine.loopfactory import random_cascade_structure

OMEGA = np.logspace(-3, 3, 200)
TRANSFORMS = [sensitivity, complementary, disk_transform(0.0)]
BANDS = [Band(), Band(0.5, 5.0)]


def _certified_equal(blocks: list[str], values: dict[str, float], count: int, rng: np.random.Generator) -> int:
    """Every certified sample's peaks (each sure) equal the per-loop path's; how many they were."""
    network = unity_feedback(blocks)
    columns = {name: value * (1 + rng.uniform(-0.2, 0.2, count)) for name, value in values.items()}
    forms = batch_pole_zero(network, "e", columns)
    assert forms is not None
    found = batch_moebius_peaks(forms, [t.moebius for t in TRANSFORMS], np.ones(count, dtype=bool))
    sure = found.certified.copy()
    for number in range(len(TRANSFORMS)):
        for band in BANDS:
            sure &= found.peak(number, band.low, band.high)[2]
    for k in np.flatnonzero(sure).tolist():
        loop = loop_model(network, "e", OMEGA, {name: float(c[k]) for name, c in columns.items()})
        for band in BANDS:
            want = refined_peaks(loop, TRANSFORMS, band)
            for number, peak in enumerate(want):
                value, frequency, _ = found.peak(number, band.low, band.high)
                assert value[k] == pytest.approx(peak.value, rel=1e-12), (k, number, band)
                if math.isfinite(peak.frequency):
                    assert frequency[k] == pytest.approx(peak.frequency, rel=1e-12), (k, number, band)
                else:
                    assert frequency[k] == peak.frequency
    return int(sure.sum())


def test_random_loops_peaks_equal_the_per_loop_path():
    """Eight random cascades (gains, real zeros and poles, light pairs, integrators), 20 samples each."""
    certified = 0
    for seed in range(8):
        rng = np.random.default_rng(100 + seed)
        blocks, values = random_cascade_structure(rng)
        certified += _certified_equal(blocks, values, 20, rng)
    assert certified >= 0.95 * 8 * 20  # 158 of 160


def test_an_uneligible_sample_is_not_certified():
    rng = np.random.default_rng(3)
    blocks, values = random_cascade_structure(rng)
    forms = batch_pole_zero(unity_feedback(blocks), "e", {n: np.full(4, v) for n, v in values.items()})
    assert forms is not None
    found = batch_moebius_peaks(forms, [sensitivity.moebius], np.array([True, False, True, False]))
    assert not found.certified[1] and not found.certified[3]
