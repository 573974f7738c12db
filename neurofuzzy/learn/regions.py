"""Where the fitted tissue differs from its description: connected **regions found**.

After a fit with the rule base as a prior (:mod:`.prior`), the elements (or springs) whose
fitted values another word fits better than their region's description ("hard" in tissue
described as "firm") form connected groups with their neighbours that leave the description on
the same side (harder or softer; elements sharing a face, springs sharing a node, within one
region); a group with at least one item that its word fits with a degree of ``MIN_DEGREE`` or
more is a region found (hysteresis, as in edge detection: a clear core, then its neighbours
that lean the same way, so a region whose values straddle the border between two words is not
cut in pieces). Each group then grows over neighbours that lean its way by more than half its
height (:func:`_grown`), so that pieces of one smoothed bump meet; candidates of two
quantities over nearly the same items are one (:func:`_merged`). A region's word is that of
the median value of its core (the items that left the description). Each is reported with
its elements or springs, nodes, centroid, size, median value, word and degree of membership,
and the rest of the tissue with its own word: "a region of 24 elements near (2.0, 2.0,
1.5) cm is hard (0.93), the rest firm".
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..forces import tetrahedron_geometry
from ..progress import note
from .power import describe_power, detection_limit
from .region_test import supported_regions
from ..constants import item_values
from .prior import _elements_sharing_a_face, _springs_sharing_a_node

__all__ = ["MIN_NODES", "describe_regions", "regions_found", "supported_regions_found"]

#: Smallest region reported, in nodes' worth of the mesh (its volume, or its springs, per
#: node): one marker's noise moves the items around its node, so a smaller region is as
#: likely noise as tissue.
MIN_NODES = 2.0
#: An item leaves the description when another word fits its value at least this well.
MIN_DEGREE = 0.5
#: A region grows over neighbours departing from its tissue's level by more than this many
#: times the scatter of the items about it (:func:`_grown`) ... The scatter, not each item's
#: linearised standard error: one item's value is barely determined alone (the data fix
#: combinations of neighbours), so its standard error says little of how far values that do
#: not depart spread. On the prior tutorial's 108 elements the standard errors of log E were
#: 0.08 to 17 (median 1.04; 0.80 to 1.03 in the stiff cell, which departs by 1.1 to 1.7),
#: the scatter 0.35: twice the standard error would have let no neighbour join anything.
GROW_TOLERANCE = 2.0
#: ... and at least this share of the description's spread (a field of equal values has no
#: scatter).
MIN_GROW = 0.05

_QUANTITIES = ("youngs_modulus", "viscosity", "poisson_ratio")


def regions_found(model, prior, *, min_nodes: float = MIN_NODES) -> dict:
    """The regions of ``model`` (fitted with ``prior``) whose words differ from the
    description.

    Parameters
    ----------
    model : Model
    prior : FuzzyPrior
    min_nodes : float
        Regions smaller than this many nodes' share of the mesh (volume for elements, springs
        for springs) are left out.

    Returns
    -------
    dict
        ``{"regions": [{"elements" or "springs": [...], "nodes": [...], "centroid": [x, y, z],
        "size": n, "volume": m³ (elements), "quantity", "value", "label", "degree",
        "described": the description's word, "region": the model's region, "share": the
        fraction of it (volume or springs) the region found covers}], "rest": {region:
        {quantity: {"value", "label"}}}}`` (values in SI units, the centroid in metres),
        regions largest first.
    """
    kind, values = item_values(model)
    if kind == "elements":
        item_region = model.elements.region
        a, b = _elements_sharing_a_face(model.mesh.tetrahedra)
        points = model.mesh.rest_positions[model.mesh.tetrahedra]
        centres = points.mean(axis=1)
        weights = tetrahedron_geometry(model.mesh).volume
        item_nodes = model.mesh.tetrahedra
    else:
        item_region = model.springs.region
        a, b = _springs_sharing_a_node(model.mesh)
        points = model.mesh.rest_positions[model.mesh.springs]
        centres, weights = points.mean(axis=1), np.ones(len(points))
        item_nodes = model.mesh.springs
        moving = model.mesh.free[model.mesh.springs].any(axis=1)
    rules = prior.rules
    found, rest = [], {}
    for quantity in _QUANTITIES:
        if quantity not in values:
            continue
        value = values[quantity]
        for region, sets in enumerate(prior.sets):
            chosen = sets.get(quantity)
            members = item_region == region
            if kind == "springs":
                members &= moving            # springs between fixed nodes say nothing
            if chosen is None or not members.any():
                continue
            variable = rules.outputs[chosen.output]
            terms = list(variable.terms)
            degrees = np.stack([variable.membership(t, value) for t in terms])
            best = np.argmax(degrees, axis=0)
            described = terms.index(prior.label(region, quantity))
            # hysteresis: items another word fits better than the description, on the same
            # side of it, join a region when it holds one that its word fits with MIN_DEGREE
            other = members & (best != described)
            seed = other & (degrees.max(axis=0) >= MIN_DEGREE)
            side = value > float(variable.to_physical(chosen.centre))
            keep = other[a] & other[b] & (side[a] == side[b])
            graph = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])),
                                  shape=(len(value), len(value)))
            _, component = connected_components(graph, directed=False)
            flagged = other & np.isin(component, component[seed])
            pieces = _grown(component, flagged, side, variable.to_internal(value), members, a,
                            b, chosen.spread)
            calm = members & ~flagged
            if calm.any():
                typical = float(np.median(value[calm]))
                rest.setdefault(model.region_names[region], {})[quantity] = {
                    "value": typical, "label": _word(rules, chosen.output, typical)[0]}
            for items, core in pieces:
                if weights[items].sum() < min_nodes * weights.sum() / model.n_nodes:
                    continue
                typical = float(np.median(value[core]))
                word, degree = _word(rules, chosen.output, typical)
                w = weights[items]
                entry = {kind: items.tolist(),
                         "nodes": np.unique(item_nodes[items]).tolist(),
                         "centroid": (w @ centres[items] / w.sum()).tolist(),
                         "size": len(items), "quantity": quantity, "value": typical,
                         "label": word, "degree": degree, "output": chosen.output,
                         "described": terms[described], "region": model.region_names[region],
                         "share": float(w.sum() / weights[members].sum()),
                         "grown_from": len(core)}
                if kind == "elements":
                    entry["volume"] = float(w.sum())
                found.append(entry)
    found = _merged(found, kind)
    found.sort(key=lambda entry: -entry["size"])
    return {"regions": found, "rest": rest}


def _grown(component, flagged, side, u, members, a, b,
           spread) -> list[tuple[np.ndarray, np.ndarray]]:
    """The pieces of one quantity in one region, grown: ``[(items, core)]``.

    ``flagged`` items (``component``: their connected pieces) leave the description, on the
    ``side`` of it (True: above) that every item of a piece shares. Their neighbours that
    depart from the region's level (the median of its items' internal values ``u``) on the
    same side as the piece join it, and so on outwards, when they depart by more than half
    the height of the lowest piece (its median departure: a step that the prior's smoothness
    term spreads out crosses half its height where the step is) and by more than
    :data:`GROW_TOLERANCE` times the items' scatter about that level (1.4826 × their median
    absolute departure: the spread the fit's errors give values that do not depart); pieces
    that meet are one region (a smooth bump whose top straddles two words, or a core cut in
    two by a word's border). ``core``: the flagged items of the grown region, whose median
    names it. A piece that is less than half of its grown region is also a candidate on its
    own (a hard core in a slightly hard shell: the region test compares them).
    """
    if not flagged.any():
        return []
    level = np.median(u[members])
    departure = u - level
    scatter = 1.4826 * np.median(np.abs(departure[members]))
    tolerance = max(GROW_TOLERANCE * scatter, MIN_GROW * spread)
    pieces = []
    for sign in (1.0, -1.0):
        cores = [label for label in np.unique(component[flagged])
                 if side[flagged & (component == label)][0] == (sign > 0)]
        if not cores:
            continue
        core = flagged & np.isin(component, cores)
        # half the height of the weakest piece: a step smoothed by the fit crosses half its
        # height at the step
        height = min(sign * np.median(departure[core & (component == label)])
                     for label in cores)
        eligible = core | (members & (sign * departure > max(tolerance, 0.5 * height)))
        keep = eligible[a] & eligible[b]
        graph = sp.coo_matrix((np.ones(int(keep.sum())), (a[keep], b[keep])),
                              shape=(len(u), len(u)))
        _, grown = connected_components(graph, directed=False)
        for label in np.unique(grown[core]):
            items = np.flatnonzero(eligible & (grown == label))
            inside = core & (grown == label)
            pieces.append((items, np.flatnonzero(inside)))
            for piece in np.unique(component[inside]):
                alone = np.flatnonzero(inside & (component == piece))
                if 2 * len(alone) < len(items):
                    pieces.append((alone, alone))
    return pieces


def _merged(found: list[dict], kind: str) -> list[dict]:
    """Candidates of different quantities over (nearly) the same items made one: a region
    whose E is harder and whose ν is lower is one hypothesis, which the region test frees
    all of (its own E, ν and η). Two merge when they share at least half of their union
    (a small candidate inside a large one stays apart: the nested case). The merged one
    keeps the entry of the larger and lists every quantity it stands for."""
    merged: list[dict] = []
    for entry in sorted(found, key=lambda e: -e["size"]):
        items = set(entry[kind])
        for other in merged:
            union = items | set(other[kind])
            if other["region"] == entry["region"] and \
                    len(items & set(other[kind])) >= 0.5 * len(union):
                other.setdefault("also", []).append(
                    {key: entry[key] for key in ("quantity", "value", "label", "degree")})
                break
        else:
            merged.append(entry)
    return merged


def describe_regions(result: dict, *, unit: float = 0.01, unit_name: str = "cm") -> str:
    """The regions found in words: "a region of 24 elements near (2.0, 2.0, 1.5) cm is hard
    (youngs_modulus 0.93); the rest: firm"."""
    parts = []
    for entry in result["regions"]:
        kind = "elements" if "elements" in entry else "springs"
        where = ", ".join(f"{c / unit:.1f}" for c in entry["centroid"])
        what = (f"all of {entry['region']} ({entry['size']} {kind}) is"
                if entry["share"] >= 1.0 - 1e-9 else
                f"a region of {entry['size']} {kind} near ({where}) {unit_name} is")
        parts.append(f"{what} {entry['label']} ({entry['quantity'].replace('_', ' ')} "
                     f"{entry['degree']:.2f}; described {entry['described']})")
    rest = "; ".join(f"{region}: " + ", ".join(f"{q.replace('_', ' ')} {v['label']}"
                                               for q, v in quantities.items())
                     for region, quantities in result["rest"].items())
    rejected = [entry for entry in result.get("rejected", [])
                if entry.get("evidence", {}).get("tested")]
    dropped = (f" ({len(rejected)} candidate region(s) explained the data no better than "
               "the homogeneous model: model error, not tissue)" if rejected else "")
    power = f"; {describe_power(result['power'])}" if result.get("power") else ""
    if not parts:
        return (f"no region differs from the description ({rest}){dropped}{power}" if rest
                else f"no region differs from the description{dropped}{power}")
    return "; ".join(parts) + (f"; the rest: {rest}" if rest else "") + dropped + power


def _word(rules, output, value) -> tuple[str, float]:
    label = rules.describe({output: value})[output]
    return label.term, float(label.degree)


def supported_regions_found(model, prior, homogeneous, experiments, *,
                            progress: bool = False) -> dict:
    """The regions of ``model`` (fitted with ``prior``) that the data support against the
    ``homogeneous`` fit (:func:`~.region_test.supported_regions` of :func:`regions_found`),
    the test's power on ``experiments`` (``"power"``, :func:`~.power.detection_limit`) and
    all that in words (``"words"``, :func:`describe_regions`); ``progress`` says it on
    stderr."""
    found = supported_regions(regions_found(model, prior), homogeneous, experiments,
                              progress=(lambda line: note(True, f"regions found: {line}"))
                              if progress else None)
    found["power"] = power = detection_limit(homogeneous, experiments)
    note(progress and power is not None, f"regions found: {describe_power(power)}")
    found["words"] = describe_regions(found)
    return found
