"""Build the MuJoCo grid model with ``mujoco.MjSpec`` (no XML templating), compile or export it.

Lengths in mm, angles in degrees at this API. :func:`build_spec` assembles the
uncompiled spec (default classes, robot and fiducial bodies from
:mod:`rfp_twin.models.mjcf.bodies`, plate, lights and cameras from :mod:`rfp_twin.models.mjcf.cameras`);
:func:`build_model` compiles it into a :class:`TwinModel`; :func:`export_model` writes
``rfp-twin.xml`` and its STL meshes. Errors raise :class:`rfp_twin.models.errors.SpecError`.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

import mujoco
import trimesh

from rfp_twin.models.errors import SpecError
from rfp_twin.models.files import atomic_write_bytes
from rfp_twin.models.geometry import RobotGeometry, geometry_for_spec
from rfp_twin.models.layout import Layout
from rfp_twin.models.mjcf.blocks import quiet_attach
from rfp_twin.models.mjcf.bodies import add_default_classes, add_grid
from rfp_twin.models.mjcf.cameras import add_scene
from rfp_twin.models.mjcf.index import ModelIndex
from rfp_twin.models.mjcf.memory import arena_bytes, check_body_count
from rfp_twin.models.mjcf.options import INTEGRATORS, MESH_DIR, MODEL_FILE, ModelOptions, servo_for
from rfp_twin.models.mjcf.twin_model import TwinModel
from rfp_twin.models.robot import RobotSpec

#: ``progress(stage, done, total)`` of a build (see :func:`build_model`).
BuildProgress = Callable[[str, int, int], None]


def build_spec(spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
               options: ModelOptions | None = None, mesh_files: dict | None = None,
               model_name: str | None = None,
               progress: BuildProgress | None = None) -> mujoco.MjSpec:
    """The uncompiled MjSpec of a grid.

    Parameters
    ----------
    spec, layout : the robots and where they stand.
    geometry : RobotGeometry, default :func:`rfp_twin.models.geometry.geometry_for_spec`.
    options : ModelOptions.
    mesh_files : dict, optional
        If given, meshes refer to files ``<name>.stl`` (in ``meshdir`` "meshes") and this
        dict is filled with file name -> trimesh for the caller to write; otherwise the
        vertices are inline.
    progress : ``progress(stage, done, total)``, called with stage "robots" as robots
        are added (done, total: robots).

    Raises
    ------
    SpecError
        Geometry that does not fit the layout (alpha arms overlapping at rest); more bodies
        than MuJoCo's collision driver handles (:func:`rfp_twin.models.mjcf.memory.check_body_count`).
    """
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    options = options if options is not None else ModelOptions()
    servo = options.servo if options.servo is not None else servo_for(spec)
    p = geometry.params
    if layout.n_robots == 0:
        raise SpecError(f"layout {layout.name!r}: no robots; allowed: at least one robot")
    check_body_count(layout.name, layout.n_robots, layout.n_fiducials)
    s = mujoco.MjSpec()
    s.modelname = model_name or f"rfp-twin-{spec.name}-{layout.name}"
    s.compiler.degree = False
    s.option.timestep = float(options.timestep_s)
    s.option.integrator = INTEGRATORS[options.integrator]
    s.option.gravity = [0.0, 0.0, -9810.0]  # mm/s^2 (no effect on z hinges)
    # arena from this grid's counts, not MuJoCo's O(dof^2) default (models/mjcf/memory.py)
    s.memory = arena_bytes(layout.n_robots, layout.n_fiducials, options.contacts_per_robot)
    if mesh_files is not None:
        s.meshdir = MESH_DIR

    vis, col = add_default_classes(s)
    base_z = p.focal_z_mm - p.fiber_z_mm
    n = layout.n_robots
    step = None if progress is None else (lambda k: progress("robots", k, n))
    add_grid(s, spec, layout, geometry, servo, options.collide_alpha, base_z, vis, col, mesh_files,
             step, robot_visuals=options.robot_visuals)
    add_scene(s, spec, layout, p, base_z, options.closeup_robot, vis)
    return s


def build_model(spec: RobotSpec, layout: Layout, geometry: RobotGeometry | None = None,
                options: ModelOptions | None = None,
                progress: BuildProgress | None = None) -> TwinModel:
    """Build and compile the grid model.

    ``progress(stage, done, total)`` (optional) follows the build: stage "robots" (robots
    added of n), then "compiling" (0 of 1, then 1 of 1). MuJoCo's compile is O(n^2) in
    the robots (``mj_setConst`` computes dense per-body Jacobians): ~1 s for 2,000 robots,
    ~25 s for 12,852.

    Returns
    -------
    TwinModel
        The MjModel, the MjSpec, the id index and the inputs.
    """
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    options = options if options is not None else ModelOptions()
    s = build_spec(spec, layout, geometry, options, progress=progress)
    if progress is not None:
        progress("compiling", 0, 1)
    try:
        with quiet_attach():
            m = s.compile()
    except ValueError as exc:
        raise SpecError(f"MuJoCo could not compile the {spec.name} model: {exc}") from None
    index = ModelIndex.from_model(m, layout, tuple(n for n, _, _ in geometry.params.fibers))
    if progress is not None:
        progress("compiling", 1, 1)
    base_z = geometry.params.focal_z_mm - geometry.params.fiber_z_mm
    return TwinModel(m, s, index, spec=spec, layout=layout, geometry=geometry, options=options,
                     base_z_mm=base_z)


def export_model(spec: RobotSpec, layout: Layout, out_dir: str | Path,
                 geometry: RobotGeometry | None = None,
                 options: ModelOptions | None = None) -> Path:
    """Write the MJCF model and its meshes: ``out_dir/rfp-twin.xml`` and
    ``out_dir/meshes/*.stl`` (binary STL, mm). Each file is written to a temp file and
    renamed. Returns the XML path; ``mujoco.MjModel.from_xml_path`` loads it.
    """
    out = Path(out_dir)
    mesh_dir = out / MESH_DIR
    try:
        mesh_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError(f"{out}: cannot create the output folder ({exc.strerror}); allowed: a "
                        "writable path") from None
    geometry = geometry if geometry is not None else geometry_for_spec(spec)
    files: dict[str, trimesh.Trimesh] = {}
    s = build_spec(spec, layout, geometry, options, mesh_files=files)
    for fname, mesh in files.items():
        atomic_write_bytes(mesh_dir / fname, mesh.export(file_type="stl"))
    s.modelfiledir = str(out)
    try:
        with quiet_attach():
            s.compile()
    except ValueError as exc:
        raise SpecError(f"MuJoCo could not compile the exported model: {exc}") from None
    xml_path = out / MODEL_FILE
    with quiet_attach():
        xml = s.to_xml()
    atomic_write_bytes(xml_path, xml.encode("utf-8"))
    return xml_path
