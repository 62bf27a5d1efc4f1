"""Every backend the machine offers either draws every kind right or refuses with a DeviceError
that names the fix — never a blank or wrong frame (issue: never a silent wrong frame).

Each configuration runs ``python -m geomtex info`` in its own process (the adapter is chosen per
process): its self-check draws a unit sphere with every object kind, traces it with ray queries
and shadow rays, and compares each with the exact intersection of the same rays with the sphere
(python/geomtex/_info.py). Under ``WGPU_BACKEND=gl`` (Mesa's llvmpipe through OpenGL) texture
sets came back blank and ray queries missed everything before the GL backend was refused.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh

import geomtex as gt
from geomtex import reference

KINDS = ["mesh", "set", "surfels", "igt", "gdm", "ray_query", "shadow"]

BACKENDS = {
    "default": {},
    "vulkan": {"WGPU_BACKEND": "vulkan"},
    "gl": {"WGPU_BACKEND": "gl"},
    "vulkan-no-int64-atomics": {"GEOMTEX_NO_INT64_ATOMICS": "1"},
    # No Vulkan driver visible at all: the CPU backend draws sets and meshes.
    "no-vulkan-driver": {"WGPU_BACKEND": "vulkan", "VK_ICD_FILENAMES": "/nonexistent/icd.json",
                         "VK_DRIVER_FILES": "/nonexistent/icd.json"},
}

#: What the CPU backend draws and traces; where `auto` falls back to it (no usable GPU adapter)
#: the other kinds are refused with the reason.
CPU_KINDS = {"mesh", "set", "ray_query", "shadow"}


@pytest.mark.parametrize("name", BACKENDS)
def test_each_backend_draws_every_kind_right_or_refuses_clearly(name: str) -> None:
    env = {**os.environ, **BACKENDS[name]}
    run = subprocess.run([sys.executable, "-m", "geomtex", "info"], env=env, capture_output=True, text=True,
                         timeout=300)
    if run.returncode == 2:
        # Refused: the message names the adapter it found and how to get a usable one.
        assert "DeviceError" in run.stderr, run.stderr
        assert "mesa-vulkan-drivers" in run.stderr and "GEOMTEX_ADAPTER" in run.stderr, run.stderr
        return
    lines = {line.split("  ")[0].removeprefix("self-check "): line for line in run.stdout.splitlines()}
    on_cpu = "backend               cpu" in run.stdout
    for kind in KINDS:
        assert kind in lines, f"{name}: no self-check line for {kind}:\n{run.stdout}\n{run.stderr}"
        if on_cpu and kind not in CPU_KINDS:
            # Refused, naming the CPU backend and how to get a usable GPU adapter.
            assert " refused (DeviceError: the CPU backend" in lines[kind], lines[kind]
            assert "mesa-vulkan-drivers" in lines[kind], lines[kind]
            continue
        assert " pass (" in lines[kind], f"{name}: {lines[kind]}\n{run.stderr}"
    assert run.returncode == 0, run.stdout + run.stderr
    # Where a GPU adapter is usable it is the default's choice; the GL and driverless runs fall
    # back to the CPU backend.
    assert on_cpu == (name in ("gl", "no-vulkan-driver")), run.stdout


def test_gl_is_refused_with_the_adapter_named() -> None:
    """On this machine (lavapipe and llvmpipe both installed) GL is offered, and refused by the
    GPU backend (``device="auto"`` then draws on the CPU backend, test above)."""
    env = {**os.environ, "WGPU_BACKEND": "gl"}
    run = subprocess.run([sys.executable, "-c", "import geomtex as gt; gt.Renderer(8, 8, device='gpu')"],
                         env=env, capture_output=True, text=True, timeout=120)
    if "no GPU adapter found" in run.stderr:
        pytest.skip("no GL adapter on this machine")
    assert run.returncode != 0
    assert "geomtex.DeviceError" in run.stderr and "(Gl," in run.stderr, run.stderr


def test_info_reports_the_adapter_and_passes_its_self_check() -> None:
    info = gt.info()
    assert info["backend"] in ("Vulkan", "Metal", "Dx12"), info
    assert int(info["max_storage_buffer_binding_size"]) >= 128 << 20
    assert info["int64_atomics"] in ("true", "false") and info["timestamps"] in ("true", "false")
    for kind in KINDS:
        result = info["self_check"][kind]
        assert result["passed"], (kind, result)
    # Measured on lavapipe: IoU 0.9964 (surfels) to 1.0, depth p90 2.3e-3 to 9.5e-3 radii.
    assert min(info["self_check"][k]["iou"] for k in KINDS if "iou" in info["self_check"][k]) >= 0.985
    assert "self-check set" in str(info)


def test_frame_normals_are_unit_length_and_point_as_trimesh_says() -> None:
    """frame.normal is documented as unit normals: lengths within 1e-6 of 1 (they were 0.99938 to
    0.99997 as stored in half floats), and their angle to trimesh's face normals at its own hits
    is what half floats allow."""
    sphere = trimesh.creation.icosphere(subdivisions=3)
    mesh = gt.Mesh(sphere.vertices, sphere.faces)
    camera = gt.Camera.look_at((0.4, 0.5, 3.0), (0.0, 0.0, 0.0), up=(0.0, 1.0, 0.0), yfov_deg=40.0)
    frame = gt.Renderer(128, 128).render(mesh, camera)
    hit = np.isfinite(frame.depth)
    lengths = np.linalg.norm(frame.normal[hit].astype(np.float64), axis=1)
    assert np.abs(lengths - 1).max() <= 2e-7, np.abs(lengths - 1).max()  # measured 4.5e-8 (float32)
    assert np.all(frame.normal[~hit] == 0)
    # Flat shading, so each pixel's normal is its face's: compare with trimesh's face at its hit.
    flat = gt.Scene()
    flat.add(mesh, normals="flat")
    frame = gt.Renderer(128, 128).render(flat, camera)
    ref = reference.raycast(mesh, camera, 128, 128)
    both = np.isfinite(frame.depth) & ref["hit"]
    faces = ref["triangle"][both]
    truth = sphere.face_normals[faces]
    cosines = np.clip(np.einsum("ij,ij->i", frame.normal[both].astype(np.float64), truth), -1, 1)
    angles = np.degrees(np.arccos(cosines))
    # Measured: median 0.0058°, p99 0.018° (half-float rounding of each component); a length of
    # 0.9997 alone reads 1.4°.
    assert np.median(angles) <= 0.017 and np.percentile(angles, 99) <= 0.05, (np.median(angles),
                                                                            np.percentile(angles, 99))
