"""The noise sampler of docs/noise.md: statistics, spherical perturbation, scaling."""
import math

import numpy as np
import pytest
from scipy import stats

from tethernet_ros.core.noise import (NoiseError, NoiseModel, NoiseSample, corner_velocities,
                                      nominal_corner_velocities, perturb_velocity)

N = 4000


@pytest.fixture(scope="module")
def samples():
    model = NoiseModel()
    return [model.sample(s) for s in range(N)]


def _arr(samples, field):
    return np.array([getattr(s, field) for s in samples])


def test_same_seed_same_sample_and_seeds_differ():
    m = NoiseModel()
    assert m.sample(11) == m.sample(11)
    assert m.sample(11) != m.sample(12)


@pytest.mark.parametrize("field, sigma", [
    ("distance_offset", 0.25),
    ("orientation_angle", math.radians(45)),
    ("closing_offset", 0.1),
])
def test_gaussian_world_and_closing_noise(samples, field, sigma):
    x = _arr(samples, field)
    assert abs(x.mean()) < 4 * sigma / math.sqrt(N)
    assert x.std(ddof=1) == pytest.approx(sigma, rel=0.05)
    assert stats.kstest(x / sigma, "norm").pvalue > 0.001


def test_per_corner_actuator_noise(samples):
    speed = _arr(samples, "speed_offsets")
    polar = _arr(samples, "polar_angles")
    azim = _arr(samples, "azimuth_angles")
    assert speed.shape == polar.shape == azim.shape == (N, 4)
    assert np.allclose(speed.std(axis=0, ddof=1), 0.25, rtol=0.06)
    assert np.allclose(polar.std(axis=0, ddof=1), math.radians(2), rtol=0.06)
    assert azim.min() >= 0 and azim.max() < 2 * math.pi
    assert stats.kstest(azim.ravel() / (2 * math.pi), "uniform").pvalue > 0.001
    # the four corners are independent
    c = np.corrcoef(speed.T)
    assert np.abs(c[np.triu_indices(4, 1)]).max() < 0.1


def test_spherical_perturbation_geometry():
    v = np.array([2.26, -2.43, 8.55])
    u = v / np.linalg.norm(v)
    for polar, az in [(0.03, 0.0), (0.03, 1.0), (-0.05, 4.0)]:
        p = perturb_velocity(v, 0.2, polar, az)
        assert np.linalg.norm(p) == pytest.approx(np.linalg.norm(v) + 0.2, rel=1e-12)
        angle = math.acos(np.clip(p @ u / np.linalg.norm(p), -1, 1))
        assert angle == pytest.approx(abs(polar), abs=1e-12)
    # the azimuth turns the tilt plane about the nominal direction
    def tilt_direction(az):
        p = perturb_velocity(v, 0.0, 0.04, az)
        t = p - (p @ u) * u
        return t / np.linalg.norm(t)

    assert abs(tilt_direction(0.0) @ tilt_direction(math.pi / 2)) < 1e-12
    assert tilt_direction(0.0) @ tilt_direction(math.pi) == pytest.approx(-1.0, abs=1e-12)


def test_polar_angle_distribution_of_perturbed_directions(samples):
    """The angle between perturbed and nominal launch direction is |N(0, 2 deg)|: a
    half-normal with mean sigma sqrt(2/pi)."""
    nominal = nominal_corner_velocities((2.26, 2.43, 8.55))
    angles = []
    for s in samples[:2000]:
        cv = corner_velocities((2.26, 2.43, 8.55), s)
        for k in range(4):
            c = cv[k] @ nominal[k] / (np.linalg.norm(cv[k]) * np.linalg.norm(nominal[k]))
            angles.append(math.acos(min(1.0, c)))
    angles = np.array(angles)
    sigma = math.radians(2)
    assert angles.mean() == pytest.approx(sigma * math.sqrt(2 / math.pi), rel=0.04)
    assert stats.kstest(angles / sigma, "halfnorm").pvalue > 0.001


def test_scale_factors_scale_spreads_with_common_random_numbers():
    base = NoiseModel()
    doubled = base.with_scales(speed=2.0, distance=0.5, closing=0.0)
    for seed in range(20):
        a, b = base.sample(seed), doubled.sample(seed)
        assert np.allclose(np.array(b.speed_offsets), 2 * np.array(a.speed_offsets), rtol=1e-15)
        assert b.distance_offset == pytest.approx(0.5 * a.distance_offset, rel=1e-15)
        assert b.closing_offset == 0.0
        assert b.polar_angles == a.polar_angles       # the other sources are untouched
        assert b.orientation_angle == a.orientation_angle


def test_nominal_sample_and_symmetric_launch():
    s = NoiseSample.nominal()
    assert s.is_nominal
    cv = corner_velocities((1.0, 2.0, 3.0), s)
    assert np.allclose(np.abs(cv), [[1, 2, 3]] * 4)
    assert np.allclose(cv.sum(axis=0)[:2], 0.0)


@pytest.mark.parametrize("kwargs, field", [
    ({"sigma_speed": -1.0}, "sigma_speed"),
    ({"sigma_polar_deg": float("nan")}, "sigma_polar_deg"),
    ({"orientation_axis": "x"}, "orientation_axis"),
    ({"scales": {"speed": 200.0}}, "scales.speed"),
    ({"scales": {"wind": 1.0}}, "scales.wind"),
])
def test_bad_noise_settings_name_the_field(kwargs, field):
    with pytest.raises(NoiseError, match=field.replace(".", r"\.")):
        NoiseModel(**kwargs)


def test_bad_seed():
    with pytest.raises(NoiseError, match="seed"):
        NoiseModel().sample(-3)
