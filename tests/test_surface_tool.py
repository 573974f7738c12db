"""A rigid tool given as a closed triangle surface (``SurfaceTool``, an instrument's tip): its
signed distance and normal against closed forms (a box, a sphere), a faceted sphere pressed
into a block against the exact sphere as its facets shrink, turning, the load-step file, and
the command line with its bad input."""

import json

import numpy as np
import pytest
import trimesh

from helpers import cli
from neurofuzzy.errors import InputError
from neurofuzzy.io import save_model
from neurofuzzy.io.load_steps import load_load_steps, save_load_steps
from neurofuzzy.load_steps import LoadSteps, ToolPath, simulate_load_steps
from neurofuzzy.mesh import from_tetra, kuhn_block
from neurofuzzy.model import Model
from neurofuzzy.observation import EmbeddedMarkers, embed_points
from neurofuzzy.simulation.contact import Sphere, SurfaceTool, contact_with
from neurofuzzy.simulation.static import Driven, equilibrium
from neurofuzzy.validation.indentation import quarter_block

E, H, R = 6000.0, 0.02, 0.004


def _ball(subdivisions):
    ball = trimesh.creation.icosphere(subdivisions=subdivisions, radius=R)
    return SurfaceTool(ball.vertices, ball.faces)


def test_a_box_s_signed_distance_and_normal_are_the_closed_form():
    """A 2 mm cube about its reference point: inside negative, outside positive, the normal
    of the nearest face; beyond the tool's reach +inf; either winding of the faces."""
    box = trimesh.creation.box(extents=(2e-3, 2e-3, 2e-3))
    for faces in (box.faces, box.faces[:, ::-1]):
        tool = SurfaceTool(box.vertices, faces)
        points = np.array([[0, 0, 1.5e-3], [0, 0, 0.7e-3], [0.2e-3, -0.9e-3, 0.1e-3],
                           [0, 0, 5e-3]])
        gap, normal, turning = tool.gap(points, np.zeros(3))
        np.testing.assert_allclose(gap[:3], [0.5e-3, -0.3e-3, -0.1e-3], atol=1e-12)
        assert gap[3] == np.inf
        np.testing.assert_allclose(normal[1], [0, 0, 1], atol=1e-9)
        np.testing.assert_allclose(normal[2], [0, -1, 0], atol=1e-9)
        assert not turning.any()
    assert tool.radius == pytest.approx(np.sqrt(3) * 1e-3)


def test_a_faceted_sphere_s_distance_is_the_sphere_s_to_its_sag():
    """Points around an icosphere (vertices on a sphere of radius R): the signed distance is
    the sphere's to within the facets' sag (the deepest face's plane, 4.4 µm), inside and
    out, and the normal the sphere's radius to within a facet's half-angle."""
    tool = _ball(4)
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(200, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    depths = rng.uniform(-0.3 * R, 0.2 * R, 200)
    points = directions * (R + depths)[:, None]
    gap, normal, _ = tool.gap(points, np.zeros(3))
    ball = trimesh.creation.icosphere(subdivisions=4, radius=R)
    sag = R - np.abs(np.einsum("ij,ij->i", ball.face_normals, ball.triangles[:, 0])).min()
    inside = np.isfinite(gap)
    assert inside.sum() > 100
    np.testing.assert_allclose(gap[inside], depths[inside], atol=1.01 * sag)
    assert np.all(np.einsum("ij,ij->i", normal[inside], directions[inside]) > 0.999)


def test_turning_the_tool_and_the_points_together_changes_nothing():
    box = trimesh.creation.box(extents=(1e-3, 2e-3, 3e-3))
    tool = SurfaceTool(box.vertices, box.faces)
    turn = trimesh.transformations.rotation_matrix(0.7, [1, 2, 3])[:3, :3]
    points = np.random.default_rng(1).uniform(-2e-3, 2e-3, size=(50, 3))
    position = np.array([1e-4, 0, -2e-4])
    plain = tool.gap(points, position)
    turned = tool.turned(turn).gap(points @ turn.T, position @ turn.T)
    np.testing.assert_allclose(turned[0], plain[0], atol=1e-12)
    near = np.isfinite(plain[0])                 # beyond the reach, no normal is wanted
    assert near.sum() > 20
    np.testing.assert_allclose(turned[1][near], plain[1][near] @ turn.T, atol=1e-9)


def test_an_open_or_malformed_surface_is_refused():
    box = trimesh.creation.box(extents=(1e-3, 1e-3, 1e-3))
    with pytest.raises(InputError, match="must be closed"):
        SurfaceTool(box.vertices, box.faces[:-1])
    with pytest.raises(InputError, match="finite"):
        SurfaceTool(box.vertices * np.nan, box.faces)


def _pressed(tool, depth):
    model, planes = quarter_block(6, half_width=0.5 * H, height=H, stretch=4.0,
                                  youngs_modulus=E, poisson_ratio=0.3)
    top = np.array([0.0, 0.0, H])
    contact = contact_with(model, tool, top + (0, 0, R - depth))
    return equilibrium(model, driven=[Driven(n, (0, 0, 0), c) for n, c in planes],
                       contact=contact, increments=1, tool_start=top + (0, 0, R))


@pytest.mark.parametrize("subdivisions, within", [(3, 0.06)])
def test_a_faceted_sphere_presses_like_the_sphere(subdivisions, within):
    """An icosphere pressed 0.4 mm into the block gives the exact sphere's force to within
    its facets' sag (its faces lie inside the sphere: a little less force)."""
    exact = _pressed(Sphere(R), 4e-4).contact_force[2]
    faceted = _pressed(_ball(subdivisions), 4e-4).contact_force[2]
    assert exact < faceted < (1 - within) * exact


@pytest.mark.slow
def test_the_faceted_sphere_s_force_converges_to_the_sphere_s():
    """The error falls about fourfold per subdivision (the sag goes as the facets' size
    squared): measured 5.0 % and 1.3 % at 0.4 mm."""
    exact = _pressed(Sphere(R), 4e-4).contact_force[2]
    errors = [abs(_pressed(_ball(k), 4e-4).contact_force[2] / exact - 1) for k in (3, 4)]
    assert errors[1] < 0.02 and errors[0] > 3 * errors[1]


def _indented(folder):
    """A block pressed by a faceted sphere in three steps, its load-step file and model."""
    points, tetrahedra = kuhn_block((4, 4, 2), H / 4)
    mesh = from_tetra(points, tetrahedra).with_fixed(where=lambda p: p[:, 2] < 1e-9)
    truth = Model.continuum(mesh, youngs_modulus=E, poisson_ratio=0.45, viscosity=1.0,
                            density=1000.0, law="neo-hookean")
    save_model(truth.with_elements(youngs_modulus=3000.0), folder / "model.yaml")
    centre = np.array([H / 2, H / 2, H / 2 + R])
    path = np.array([centre - (0, 0, d) for d in (0.0, 2e-4, 4e-4, 6e-4)])
    tool = ToolPath(_ball(3), path, name="tip")
    beads = EmbeddedMarkers(*embed_points(mesh, np.array([[0.3 * H, 0.3 * H, 0.4 * H]]))[:2],
                            np.zeros((4, 1, 3)))
    pressed = simulate_load_steps(truth, [], beads, force_noise=1e-6, seed=2, tool=tool)
    return LoadSteps(mesh, (), None, pressed.reaction, tool=tool), path


def test_a_surface_tool_goes_through_the_load_step_file_and_fits(tmp_path):
    data, _ = _indented(tmp_path)
    save_load_steps(data, tmp_path / "steps.npz")
    back = load_load_steps(tmp_path / "steps.npz")
    assert isinstance(back.tool.tool, SurfaceTool)
    np.testing.assert_array_equal(back.tool.tool.faces, data.tool.tool.faces)
    np.testing.assert_allclose(back.tool.tool.vertices, data.tool.tool.vertices)
    done = cli("fit", tmp_path / "steps.npz", "--start", tmp_path / "model.yaml", "--json",
               "--quiet", "--no-mesh-check")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["youngs_modulus"] == pytest.approx(E, rel=0.01)


def test_import_takes_a_surface_file_with_its_unit_and_refuses_one_without(tmp_path):
    data, path = _indented(tmp_path)
    ball = trimesh.creation.icosphere(subdivisions=3, radius=R * 1e3)       # in mm
    ball.export(tmp_path / "tip.stl")
    trimesh.Trimesh(ball.vertices, ball.faces[:-3]).export(tmp_path / "open.stl")
    rows = ["# length units: mm", "# force units: mN", "step,x,y,z,fx,fy,fz",
            "0," + ",".join(f"{v * 1e3:.6f}" for v in path[0]) + ",0,0,0"]
    rows += [f"{s}," + ",".join(f"{v * 1e3:.6f}" for v in path[s]) + ","
             + ",".join(f"{f * 1e3:.6f}" for f in data.reaction[s - 1]) for s in (1, 2, 3)]
    (tmp_path / "tool.csv").write_text("\n".join(rows) + "\n")

    def run(tool, out):
        return cli("import", "--topology", tmp_path / "model.yaml", "--tool", tool,
                   "--tool-path", tmp_path / "tool.csv", "--out", tmp_path / out)

    done = run(f"surface:{tmp_path / 'tip.stl'},units=mm", "pressed.npz")
    assert done.returncode == 0, done.stderr
    assert "a surface of 1280 triangles reaching 4 mm pressed 0.6 mm" in done.stdout
    read = load_load_steps(tmp_path / "pressed.npz").tool.tool
    assert read.radius == pytest.approx(R)
    for tool, message in ((f"surface:{tmp_path / 'tip.stl'}", "states no unit"),
                          (f"surface:{tmp_path / 'open.stl'},units=mm", "must be closed"),
                          (f"surface:{tmp_path / 'none.stl'},units=mm", "no such file")):
        refused = run(tool, "refused.npz")
        assert refused.returncode == 2 and message in refused.stderr, refused.stderr
        assert not (tmp_path / "refused.npz").exists()
