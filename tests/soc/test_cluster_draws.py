"""soc.culling.cluster_draws: the indirect commands of chosen clusters cover exactly those
clusters' indices, one command per run of consecutive chosen clusters of an object, in the
objects' order; clusters_of lists an object's clusters in order."""

from __future__ import annotations

import numpy as np

import soc
from soc.culling.cluster_draws import cluster_commands, clusters_of
from soc.culling.clusters import scene_clusters
from soc.scenes.primitives import icosphere, sheet, translate


def _scene() -> soc.Scene:
    meshes = [sheet(4.0, 4.0, 8, 8), translate(icosphere(1.0, 2), (5, 0, 0)), icosphere(0.5, 0)]
    return soc.Scene.from_meshes(meshes)


def test_commands_cover_exactly_the_chosen_clusters_in_runs():
    scene = _scene()
    cl = scene_clusters(scene, 4)
    base = scene.vertex_offsets[:-1]
    rng = np.random.default_rng(0)
    for trial in range(20):
        chosen = rng.random(len(cl.first)) < 0.5
        objects = rng.permutation(len(scene))[: 1 + trial % len(scene)]
        commands, triangles = cluster_commands(objects, cl, chosen, base)
        wanted = clusters_of(objects, cl)
        wanted = wanted[chosen[wanted]]
        assert triangles == int(cl.count[wanted].sum())
        # Index ranges drawn, per object, against the chosen clusters' ranges.
        drawn = {(int(c[4]), i) for c in commands for i in range(c[2], c[2] + c[0])}
        expect = {
            (int(cl.object[c]), i)
            for c in wanted
            for i in range(3 * cl.first[c], 3 * (cl.first[c] + cl.count[c]))
        }
        assert drawn == expect
        assert all(c[1] == 1 and c[3] == base[c[4]] for c in commands)
        # One command per run: a chosen cluster whose predecessor in its object is chosen
        # too does not start a command.
        starts = sum(
            1 for c in wanted if c == cl.object_clusters[cl.object[c]] or not chosen[c - 1]
        )
        assert len(commands) == starts
        # Objects in the order given.
        order = [int(c[4]) for c in commands]
        ranks = {int(o): k for k, o in enumerate(objects)}
        assert order == sorted(order, key=ranks.__getitem__)


def test_clusters_of_lists_object_ranges_in_order():
    scene = _scene()
    cl = scene_clusters(scene, 4)
    bounds = cl.object_clusters
    objects = np.array([2, 0])
    assert np.array_equal(
        clusters_of(objects, cl),
        np.r_[np.arange(bounds[2], bounds[3]), np.arange(bounds[0], bounds[1])],
    )
    several = clusters_of(np.arange(len(scene)), cl, several=True)
    lone = np.diff(bounds) == 1
    assert len(several) == int(np.diff(bounds)[~lone].sum())
    assert len(clusters_of(np.zeros(0, np.int64), cl)) == 0
