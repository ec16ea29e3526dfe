"""The critical-distance average (outputs/disc.py): the analytic average of a smooth field, the same
average on every mesh for a field the mesh represents exactly, and the maximum over positions."""

from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI
from scipy.optimize import brentq

from suture_fem.outputs.disc import CellField, disc_averages, disc_rule, max_disc_average, overlap_averages

#: A piece of the r-z section away from the axis: r in [0.5, 1.5], z in [0, 1].
BOX = [[0.5, 0.0], [1.5, 1.0]]
RADIUS = 0.15


def _mesh(n, diagonal="right"):
    import dolfinx.mesh

    diagonal = getattr(dolfinx.mesh.DiagonalType, diagonal)
    return dolfinx.mesh.create_rectangle(MPI.COMM_WORLD, [np.array(p) for p in BOX], [n, n],
                                         dolfinx.mesh.CellType.triangle, diagonal=diagonal)


def _field(mesh, f):
    """The field f(r, z) sampled at three interior points of every owned cell, as the outputs do."""
    from suture_fem.support import compat

    num = mesh.topology.index_map(2).size_local
    cells = np.arange(num, dtype=np.int32)
    xv = mesh.geometry.x[compat.geometry_dofs(mesh)[cells][:, :3], :2]  # (n, 3, 2) vertices
    bary = np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]])
    xy = np.einsum("qv,nvd->nqd", bary, xv)
    return CellField(mesh, cells, xy, f(xy[..., 0], xy[..., 1]))


def test_the_disc_rule_weights_sum_to_the_area():
    offsets, weights = disc_rule(RADIUS)
    assert weights.sum() == pytest.approx(np.pi * RADIUS**2, rel=1e-13)
    assert np.max(np.hypot(*offsets.T)) < RADIUS


def test_the_average_of_a_smooth_field_is_its_analytic_average():
    # 2 pi r-weighted averages over a disc of radius R at (r0, z0): <r^2> = r0^2 + 3 R^2 / 4,
    # <z^3> = z0^3 + 3 z0 R^2 / 4 (the odd angular moments vanish).
    centres = np.array([[0.9, 0.4], [1.1, 0.6]])
    exact = centres[:, 0] ** 2 + 3 * RADIUS**2 / 4 + centres[:, 1] ** 3 + 3 * centres[:, 1] * RADIUS**2 / 4
    errors = []
    for n in (20, 40):
        got = disc_averages(_field(_mesh(n), lambda r, z: r**2 + z**3), centres, RADIUS)
        errors.append(np.max(np.abs(got - exact) / exact))
    assert errors[1] < 1e-5
    assert errors[0] / errors[1] > 3.5  # the per-cell linear fit: at least second order in h


def test_the_average_is_the_same_on_every_mesh_for_a_field_it_represents_exactly():
    f = lambda r, z: 2.0 + 3.0 * r - 1.5 * z  # noqa: E731
    # discs inside, cut by the boundary, and one centred outside (none)
    centres = np.array([[1.0, 0.5], [0.55, 0.3], [1.45, 0.95], [1.7, 0.5]])
    a = disc_averages(_field(_mesh(12, "right"), f), centres, RADIUS)
    b = disc_averages(_field(_mesh(31, "left"), f), centres, RADIUS)
    assert a[:3] == pytest.approx(b[:3], rel=1e-12)
    assert a[3] == b[3] == -np.inf
    # fully inside: the analytic average 2 + 3 (r0 + R^2 / (4 r0)) - 1.5 z0
    assert a[0] == pytest.approx(2 + 3 * (1.0 + RADIUS**2 / 4.0) - 0.75, rel=1e-12)
    ma = max_disc_average(_field(_mesh(12, "right"), f), np.array([[1.4, 0.1]]), RADIUS)
    mb = max_disc_average(_field(_mesh(31, "left"), f), np.array([[1.4, 0.1]]), RADIUS)
    assert ma.value == pytest.approx(mb.value, rel=1e-12) and ma.at == pytest.approx(mb.at, abs=1e-12)


def test_the_maximum_over_positions_finds_the_analytic_maximum():
    # f = 1 - (r - r1)^2 - (z - z1)^2: A(r0, z0) = 1 - (r0 - r1)^2 - (r0 - r1) R^2 / (2 r0) - R^2 / 2 - (z0 - z1)^2,
    # largest at z0 = z1 and 2 (r0 - r1) + R^2 r1 / (2 r0^2) = 0.
    r1, z1 = 1.0, 0.5
    r0 = brentq(lambda r: 2 * (r - r1) + RADIUS**2 * r1 / (2 * r**2), 0.8, 1.0)
    exact = 1 - (r0 - r1) ** 2 - (r0 - r1) * RADIUS**2 / (2 * r0) - RADIUS**2 / 2
    n = 80
    found = max_disc_average(_field(_mesh(n), lambda r, z: 1 - (r - r1) ** 2 - (z - z1) ** 2),
                             np.array([[1.2, 0.3]]), RADIUS)
    assert found.value == pytest.approx(exact, rel=1e-4)
    # A is flat near its top: the per-cell fit's O(h^2) error moves the maximiser by a fraction of an element
    assert found.at == pytest.approx([r0, z1], abs=0.5 / n)


def test_the_search_ranks_its_candidates_by_their_disc_average_not_their_point_value():
    # three narrow spikes of height 10, R or more apart (the largest point values, small averages), and a
    # broad bump of height 2 at (1.2, 0.7): the largest average is the bump's. The rule before 9886386 (climb
    # from the three largest point values at least R apart) starts at the three spikes and misses it.
    from suture_fem.outputs.disc import STARTS, top_points

    spikes = [(0.6, 0.2), (0.6, 0.45), (0.85, 0.2)]

    def f(r, z):
        # each spike on a small hill of its own, a local maximum of the disc average that holds a climb
        narrow = sum(10 * np.exp(-((r - a) ** 2 + (z - b) ** 2) / 0.02**2)
                     + 0.5 * np.exp(-((r - a) ** 2 + (z - b) ** 2) / 0.1**2) for a, b in spikes)
        return narrow + 2 * np.exp(-((r - 1.2) ** 2 + (z - 0.7) ** 2) / 0.3**2)

    field = _field(_mesh(40), f)
    values, xy = field.coeffs[:, 0], field.centre  # one value per cell is enough to rank points here
    old_starts = top_points(MPI.COMM_WORLD, values, xy, RADIUS, count=STARTS)
    nearest_spike = np.min([np.hypot(*(old_starts - s).T) for s in spikes], axis=0)
    assert np.all(nearest_spike < 0.05)  # the three largest values R apart: one at each spike
    old = max_disc_average(field, old_starts, RADIUS)
    found = max_disc_average(field, top_points(MPI.COMM_WORLD, values, xy, RADIUS), RADIUS)
    assert found.at == pytest.approx([1.2, 0.7], abs=0.05) and found.value > old.value
    assert np.hypot(*(np.asarray(old.at) - [1.2, 0.7])) > 0.3  # the old rule's climb did not reach the bump


def _spikes_and_bump(r, z):
    """Three narrow spikes of height 10 on hills of their own, and a broad bump of height 2 at (1.2, 0.7)."""
    spikes = [(0.6, 0.2), (0.6, 0.45), (0.85, 0.2)]
    narrow = sum(10 * np.exp(-((r - a) ** 2 + (z - b) ** 2) / 0.02**2)
                 + 0.5 * np.exp(-((r - a) ** 2 + (z - b) ** 2) / 0.1**2) for a, b in spikes)
    return narrow + 2 * np.exp(-((r - 1.2) ** 2 + (z - 0.7) ** 2) / 0.3**2)


def test_the_coarse_view_finds_what_a_finely_meshed_corner_hides_from_the_largest_point_values():
    # A finely meshed corner has many more points than the rest: 3 x 10,000 points within 0.03 of the
    # spikes, every one of them above the bump's largest value, fill the pool of largest point values that
    # top_points draws from; its candidates are the spikes only, whose climbs stay on their hills. The
    # coarse view (the field on a grid fixed in space, averaged over R) sees the bump.
    from suture_fem.outputs.disc import coarse_starts, top_points

    rng = np.random.default_rng(1)
    rho, theta = 0.03 * np.sqrt(rng.random(30000)), 2 * np.pi * rng.random(30000)
    centres = np.repeat([(0.6, 0.2), (0.6, 0.45), (0.85, 0.2)], 10000, axis=0)
    dense = centres + np.column_stack([rho * np.cos(theta), rho * np.sin(theta)])
    field = _field(_mesh(40), _spikes_and_bump)
    xy = np.concatenate([dense, field.centre])
    values = _spikes_and_bump(xy[:, 0], xy[:, 1])
    assert np.sort(values)[-2400] > 2.0  # the pool of 50 x 48 largest values lies at the spikes
    by_value = top_points(MPI.COMM_WORLD, values, xy, RADIUS)
    assert len(by_value) == 3
    missed = max_disc_average(field, by_value, RADIUS)
    assert np.hypot(*(np.asarray(missed.at) - [1.2, 0.7])) > 0.3
    coarse = coarse_starts(field, *np.array(BOX), RADIUS)
    assert np.hypot(*(coarse[0] - [1.2, 0.7])) < RADIUS  # the coarse view's best node is at the bump
    found = max_disc_average(field, (by_value, coarse), RADIUS)
    assert found.at == pytest.approx([1.2, 0.7], abs=0.05) and found.value > missed.value


def test_a_search_restricted_to_a_zone_finds_the_zone_s_largest_average_and_stays_in_it():
    field = _field(_mesh(40), _spikes_and_bump)
    everywhere = max_disc_average(field, np.array([[1.2, 0.6], [0.6, 0.3]]), RADIUS)
    near_spikes = lambda c: np.hypot(c[:, 0] - 0.6, c[:, 1] - 0.3) <= 0.3  # noqa: E731
    zone = max_disc_average(field, np.array([[1.2, 0.6], [0.6, 0.3]]), RADIUS, near_spikes)
    assert everywhere.at == pytest.approx([1.2, 0.7], abs=0.05)
    assert near_spikes(np.array([zone.at]))[0] and zone.value < everywhere.value
    # the zone's best disc is the best of a fine scan of the zone (grid R/8), up to the search's resolution, of
    # the average the search reports (the cells' overlaps; the point rule's scan reads 0.771 against 0.727)
    g = np.stack(np.meshgrid(np.arange(0.3, 0.91, RADIUS / 8), np.arange(0.0, 0.61, RADIUS / 8)), -1).reshape(-1, 2)
    scan = np.max(overlap_averages(field, g, RADIUS, near_spikes))
    assert zone.value >= scan * (1 - 1e-3)


def test_the_distance_to_a_cone_surface_follows_its_lines_and_its_arcs():
    from types import SimpleNamespace

    from suture_fem.outputs.critical_distance import cone_distance

    # a line from (0, 0) to (1, 0), then a quarter circle of radius 1 about (1, 1) from (1, 0) to (2, 1)
    cone = SimpleNamespace(outline=[("line", ((0.0, 0.0), (1.0, 0.0))), ("arc", ((1.0, 0.0), (1.0, 1.0), (2.0, 1.0)))])
    s = np.sqrt(0.5)
    points = np.array([[0.5, -0.3], [1 + 1.2 * s, 1 - 1.2 * s], [1 + 0.5 * s, 1 - 0.5 * s], [1.0, 2.3]])
    # beside the line; outside and inside the arc; beyond the arc's end, where the full circle would be 0.3 away
    expected = [0.3, 0.2, 0.5, np.hypot(1.0, 1.3)]
    assert cone_distance([cone], points) == pytest.approx(expected, abs=2e-3)  # 16 chords: sagitta 1.2e-3
    assert np.all(cone_distance([], points) == np.inf)


def test_the_largest_value_per_point_equals_numpy_s_maximum_at():
    # CellField.at takes the larger value where a point lies in two cells (an edge), sorted or not
    from suture_fem.outputs.disc_points import _max_into

    rng = np.random.default_rng(0)
    for trial in range(50):
        n, m = int(rng.integers(0, 60)), int(rng.integers(1, 20))
        idx = np.sort(rng.integers(0, m, n)) if trial % 2 else rng.integers(0, m, n)
        vals, start = rng.normal(size=n), np.where(rng.random(m) < 0.5, -np.inf, rng.normal(size=m))
        expected, got = start.copy(), start.copy()
        np.maximum.at(expected, idx, vals)
        _max_into(got, idx, vals)
        assert np.array_equal(got, expected)


def test_spread_takes_candidates_in_order_each_far_enough_from_those_taken_before():
    from suture_fem.outputs.disc import spread

    rng = np.random.default_rng(3)
    for trial in range(40):
        candidates = np.round(rng.normal(size=(int(rng.integers(0, 400)), 2)), 1 if trial % 2 else 6)
        separation, count = float(rng.uniform(0.05, 1.0)), int(rng.integers(1, 30))
        expected = []  # the definition, one candidate at a time
        for c in candidates:
            if len(expected) < count and all(np.hypot(*(c - t)) >= separation for t in expected):
                expected.append(c)
        assert np.array_equal(spread(candidates, separation, count), np.array(expected).reshape(-1, 2))


def test_the_candidates_order_is_the_lexsort_of_value_r_and_z_largest_first():
    from suture_fem.outputs.candidates import _descending

    rng = np.random.default_rng(8)
    for trial in range(60):
        n = int(rng.integers(0, 80))
        rows = rng.normal(size=(n, 3)) if trial % 3 else np.round(rng.normal(size=(n, 3)), 1)  # equal values
        if trial % 7 == 3 and n:
            rows[int(rng.integers(0, n)), 0] = np.nan
        if trial % 5 == 4 and n > 1:
            rows[:2, 0] = -0.0, 0.0
        assert np.array_equal(_descending(rows), np.lexsort((-rows[:, 2], -rows[:, 1], -rows[:, 0])))


def test_the_largest_values_by_partition_are_the_set_the_sort_takes():
    from suture_fem.outputs.candidates import _largest

    rng = np.random.default_rng(5)
    for trial in range(30):
        n = int(rng.integers(1, 300))
        values = rng.normal(size=n) if trial % 3 else np.round(rng.normal(size=n), 1)  # ties at the cut
        if trial % 10 == 7:
            values[int(rng.integers(0, n))] = np.nan
        k = int(rng.integers(1, 60))
        by_sort = np.argsort(values)[::-1][:k]
        got = _largest(values, k)
        assert sorted(got.tolist()) == sorted(by_sort.tolist())


def test_window_sums_are_numpy_s_sums_of_the_shifted_arrays_bit_for_bit():
    from suture_fem.outputs.disc import _STENCIL, _shifts, _window_sum

    rng = np.random.default_rng(6)
    a = rng.normal(size=(37, 23)) * 10.0 ** rng.integers(-8, 8, (37, 23))
    assert np.array_equal(_window_sum(a, _STENCIL, 0.0), np.sum(_shifts(a, _STENCIL, 0.0), axis=0))


def test_a_field_of_two_sets_of_cells_is_their_two_fits_in_order_and_the_coarse_view_kept_is_the_same():
    from suture_fem.outputs.disc import coarse_starts
    from suture_fem.outputs.disc_points import DiscPoints
    from suture_fem.support import compat

    mesh = _mesh(12)
    whole = _field(mesh, _spikes_and_bump)
    half = len(whole.cells) // 2
    xy = np.einsum("qv,nvd->nqd", np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]),
                   mesh.geometry.x[compat.geometry_dofs(mesh)[whole.cells][:, :3], :2])
    values = _spikes_and_bump(xy[..., 0], xy[..., 1])
    parts = [CellField(mesh, whole.cells[s], xy[s], values[s]) for s in (slice(None, half), slice(half, None))]
    assert np.array_equal(np.concatenate([p.coeffs for p in parts]), whole.coeffs)
    # a kept coarse view (grid, weights, window sums) gives what a fresh one gives, for one field and the next
    discs = DiscPoints(compat.cell_locator(mesh, whole.cells))
    for f in (_spikes_and_bump, lambda r, z: 1.0 + r * z, _spikes_and_bump):
        fresh = _field(mesh, f)
        kept = CellField(mesh, fresh.cells, xy, f(xy[..., 0], xy[..., 1]), discs.locate, discs)
        assert np.array_equal(coarse_starts(kept, *np.array(BOX), RADIUS), coarse_starts(fresh, *np.array(BOX), RADIUS))
    assert len(discs.coarse) == 1


def test_disc_averages_from_kept_points_are_the_fresh_ones_bit_for_bit():
    from suture_fem.outputs.disc_points import DiscPoints
    from suture_fem.support import compat

    mesh = _mesh(12)
    fresh = _field(mesh, _spikes_and_bump)
    xy = np.einsum("qv,nvd->nqd", np.array([[2 / 3, 1 / 6, 1 / 6], [1 / 6, 2 / 3, 1 / 6], [1 / 6, 1 / 6, 2 / 3]]),
                   mesh.geometry.x[compat.geometry_dofs(mesh)[fresh.cells][:, :3], :2])
    rng = np.random.default_rng(3)
    batches = [rng.uniform([0.4, -0.1], [1.6, 1.1], (n, 2)) for n in (7, 30, 1)]
    batches.append(np.concatenate([batches[1][5:], batches[0], [[3.0, 3.0]]]))  # kept, new and outside centres
    for limit in (0, 2_000_000):  # nothing kept (each batch prepared alone), and every centre kept
        discs = DiscPoints(compat.cell_locator(mesh, fresh.cells), limit=limit)
        for f in (_spikes_and_bump, lambda r, z: 1.0 + r * z):
            kept = CellField(mesh, fresh.cells, xy, f(xy[..., 0], xy[..., 1]), discs.locate, discs)
            alone = _field(mesh, f)
            for centres in batches:
                assert np.array_equal(disc_averages(kept, centres, RADIUS), disc_averages(alone, centres, RADIUS))
