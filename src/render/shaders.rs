//! WGSL sources, assembled from `shaders/`. WGSL has no #include, so each pipeline's module is its
//! files concatenated in one order: types, then bindings, then functions, then the pass's entry
//! points. Each bind group's bindings are declared in exactly one `*_bindings.wgsl` file.

macro_rules! shader {
    ($file:literal) => {
        include_str!(concat!("../../shaders/", $file))
    };
}

const CAMERA_TYPES: &str = shader!("camera_types.wgsl");
const TARGETS_TYPES: &str = shader!("targets_types.wgsl");
const SEARCH_TYPES: &str = shader!("search_types.wgsl");
const GTEX_TYPES: &str = shader!("gtex_types.wgsl");
const MESH_TYPES: &str = shader!("mesh_types.wgsl");
const GDM_TYPES: &str = shader!("gdm_types.wgsl");
const GDM_BINDINGS: &str = shader!("gdm_bindings.wgsl");
const GDM_FUNCTIONS: &str = shader!("gdm_functions.wgsl");
const GDM_RASTER: &str = shader!("gdm_raster.wgsl");
const GDM_TRACE_BINDINGS: &str = shader!("gdm_trace_bindings.wgsl");
const GDM_TRACE_FUNCTIONS: &str = shader!("gdm_trace_functions.wgsl");
const GDM_TRACE_RAYS: &str = shader!("gdm_trace_rays.wgsl");
const TRACE_TYPES: &str = shader!("trace_types.wgsl");
const QUERY_TYPES: &str = shader!("query_types.wgsl");
const SURFELS_TYPES: &str = shader!("surfels_types.wgsl");
const IGT_TYPES: &str = shader!("igt_types.wgsl");
const IGT_BINDINGS: &str = shader!("igt_bindings.wgsl");
const IGT_FUNCTIONS: &str = shader!("igt_functions.wgsl");
const IGT_RASTER: &str = shader!("igt_raster.wgsl");
const IGT_SURFACE: &str = shader!("igt_surface.wgsl");

const FRAME_BINDINGS: &str = shader!("frame_bindings.wgsl");
const GTEX_BINDINGS: &str = shader!("gtex_bindings.wgsl");
const MESH_BINDINGS: &str = shader!("mesh_bindings.wgsl");
const QUERY_BINDINGS: &str = shader!("query_bindings.wgsl");
const GTEX_PIECES_BINDINGS: &str = shader!("gtex_pieces_bindings.wgsl");
const TILES_BINDINGS: &str = shader!("tiles_bindings.wgsl");
const TILES_FUNCTIONS: &str = shader!("tiles_functions.wgsl");
const TILES_QUERY_FUNCTIONS: &str = shader!("tiles_query_functions.wgsl");
const GTEX_TRACE_BINDINGS: &str = shader!("gtex_trace_bindings.wgsl");
const MESH_TRACE_BINDINGS: &str = shader!("mesh_trace_bindings.wgsl");
const DEPTH_COPY_BINDINGS: &str = shader!("depth_copy_bindings.wgsl");
const SURFELS_BINDINGS: &str = shader!("surfels_bindings.wgsl");
const SURFELS_VIS64_BINDINGS: &str = shader!("surfels_vis64_bindings.wgsl");
const SURFELS_VIS32_BINDINGS: &str = shader!("surfels_vis32_bindings.wgsl");
const SURFELS_ARGS_BINDINGS: &str = shader!("surfels_args_bindings.wgsl");
const SURFELS_RESOLVE_BINDINGS: &str = shader!("surfels_resolve_bindings.wgsl");

const CAMERA_FUNCTIONS: &str = shader!("camera_functions.wgsl");
const HEIGHTFIELD_FUNCTIONS: &str = shader!("heightfield_functions.wgsl");
const GTEX_PIECE_FUNCTIONS: &str = shader!("gtex_piece_functions.wgsl");
const RAY_BOX_FUNCTIONS: &str = shader!("ray_box_functions.wgsl");
const TRACE_FUNCTIONS: &str = shader!("trace_functions.wgsl");
const QUERY_INDEX_FUNCTIONS: &str = shader!("query_index_functions.wgsl");
const QUERY_FUNCTIONS: &str = shader!("query_functions.wgsl");
const GTEX_FRAGMENT_FUNCTIONS: &str = shader!("gtex_fragment_functions.wgsl");
const GTEX_TILES_FUNCTIONS: &str = shader!("gtex_tiles_functions.wgsl");
const GTEX_TRACE_FUNCTIONS: &str = shader!("gtex_trace_functions.wgsl");
const MESH_TRACE_FUNCTIONS: &str = shader!("mesh_trace_functions.wgsl");
const RAY_TRIANGLE_FUNCTIONS: &str = shader!("ray_triangle_functions.wgsl");
const SURFELS_FUNCTIONS: &str = shader!("surfels_functions.wgsl");
const SURFELS_CLIP_FUNCTIONS: &str = shader!("surfels_clip_functions.wgsl");

const GTEX_RAYCAST: &str = shader!("gtex_raycast.wgsl");
const GTEX_TILES: &str = shader!("gtex_tiles.wgsl");
const GTEX_TILES_RAYS: &str = shader!("gtex_tiles_rays.wgsl");
const GTEX_TRACE_RAYS: &str = shader!("gtex_trace_rays.wgsl");
const MESH_TRACE_RAYS: &str = shader!("mesh_trace_rays.wgsl");
const MESH_TILES_RAYS: &str = shader!("mesh_tiles_rays.wgsl");
const MESH_RASTER: &str = shader!("mesh_raster.wgsl");
const DEPTH_COPY: &str = shader!("depth_copy.wgsl");
const SURFELS_CULL: &str = shader!("surfels_cull.wgsl");
const SURFELS_ARGS: &str = shader!("surfels_args.wgsl");
const SURFELS_SPLAT64: &str = shader!("surfels_splat64.wgsl");
const SURFELS_SPLAT_DEPTH32: &str = shader!("surfels_splat_depth32.wgsl");
const SURFELS_SPLAT_ID32: &str = shader!("surfels_splat_id32.wgsl");
const SURFELS_RESOLVE: &str = shader!("surfels_resolve.wgsl");

fn assemble(parts: &[&str]) -> String {
    parts.join("\n")
}

/// A geometry-texture primary pass (kinds/gtex): its extra bindings and its entry points.
fn gtex_primary(bindings: &[&str], functions: &[&str], entry: &str) -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GTEX_TYPES,
        TARGETS_TYPES,
        FRAME_BINDINGS,
        GTEX_BINDINGS,
        &bindings.concat(),
        CAMERA_FUNCTIONS,
        HEIGHTFIELD_FUNCTIONS,
        RAY_BOX_FUNCTIONS,
        GTEX_PIECE_FUNCTIONS,
        GTEX_FRAGMENT_FUNCTIONS,
        &functions.concat(),
        entry,
    ])
}

/// The geometry-texture pass drawing every box (kinds/gtex).
pub fn gtex_raycast() -> String {
    gtex_primary(&[], &[], GTEX_RAYCAST)
}

/// The tiled geometry-texture pass, boxes front to back per pixel (kinds/gtex/tiles.rs).
pub fn gtex_tiles() -> String {
    let bindings = [GTEX_PIECES_BINDINGS, TILES_BINDINGS];
    gtex_primary(
        &bindings,
        &[TILES_FUNCTIONS, GTEX_TILES_FUNCTIONS],
        GTEX_TILES,
    )
}

/// Parallel ray queries (shadow rays toward a directional light) through geometry-texture sets,
/// tiled as seen along the rays (kinds/gtex/tiles.rs, query.rs).
pub fn gtex_tiles_rays() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GTEX_TYPES,
        QUERY_TYPES,
        FRAME_BINDINGS,
        GTEX_BINDINGS,
        GTEX_PIECES_BINDINGS,
        TILES_BINDINGS,
        QUERY_BINDINGS,
        HEIGHTFIELD_FUNCTIONS,
        RAY_BOX_FUNCTIONS,
        GTEX_PIECE_FUNCTIONS,
        TILES_FUNCTIONS,
        GTEX_TILES_FUNCTIONS,
        QUERY_INDEX_FUNCTIONS,
        TILES_QUERY_FUNCTIONS,
        GTEX_TILES_RAYS,
    ])
}

/// Ray queries through geometry-texture sets (kinds/gtex, query.rs).
pub fn gtex_trace_rays() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GTEX_TYPES,
        TRACE_TYPES,
        QUERY_TYPES,
        FRAME_BINDINGS,
        GTEX_BINDINGS,
        GTEX_PIECES_BINDINGS,
        GTEX_TRACE_BINDINGS,
        QUERY_BINDINGS,
        HEIGHTFIELD_FUNCTIONS,
        RAY_BOX_FUNCTIONS,
        GTEX_PIECE_FUNCTIONS,
        TRACE_FUNCTIONS,
        QUERY_INDEX_FUNCTIONS,
        QUERY_FUNCTIONS,
        GTEX_TRACE_FUNCTIONS,
        GTEX_TRACE_RAYS,
    ])
}

/// Ray queries through meshes (kinds/mesh.rs, query.rs).
pub fn mesh_trace_rays() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        MESH_TYPES,
        TRACE_TYPES,
        QUERY_TYPES,
        FRAME_BINDINGS,
        MESH_TRACE_BINDINGS,
        QUERY_BINDINGS,
        RAY_BOX_FUNCTIONS,
        TRACE_FUNCTIONS,
        QUERY_INDEX_FUNCTIONS,
        QUERY_FUNCTIONS,
        RAY_TRIANGLE_FUNCTIONS,
        MESH_TRACE_FUNCTIONS,
        MESH_TRACE_RAYS,
    ])
}

/// Parallel ray queries (shadow rays toward a directional light) through meshes, their triangles
/// tiled as seen along the rays (kinds/mesh.rs, kinds/tiles.rs, query.rs).
pub fn mesh_tiles_rays() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        MESH_TYPES,
        TRACE_TYPES,
        QUERY_TYPES,
        FRAME_BINDINGS,
        MESH_TRACE_BINDINGS,
        TILES_BINDINGS,
        QUERY_BINDINGS,
        QUERY_INDEX_FUNCTIONS,
        TILES_FUNCTIONS,
        TILES_QUERY_FUNCTIONS,
        RAY_TRIANGLE_FUNCTIONS,
        MESH_TRACE_FUNCTIONS,
        MESH_TILES_RAYS,
    ])
}

/// The mesh pass (kinds/mesh.rs).
pub fn mesh_raster() -> String {
    // Group 0 is the frame's for every raster pass, so the mesh module carries the search
    // types too, unused.
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        MESH_TYPES,
        TARGETS_TYPES,
        FRAME_BINDINGS,
        MESH_BINDINGS,
        CAMERA_FUNCTIONS,
        MESH_RASTER,
    ])
}

/// The displacement-shell pass (kinds/gdm.rs).
pub fn gdm_raster() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GDM_TYPES,
        TARGETS_TYPES,
        FRAME_BINDINGS,
        GDM_BINDINGS,
        CAMERA_FUNCTIONS,
        GDM_FUNCTIONS,
        GDM_RASTER,
    ])
}

/// Ray queries through displacement shells (kinds/gdm.rs, query.rs).
pub fn gdm_trace_rays() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GDM_TYPES,
        TRACE_TYPES,
        QUERY_TYPES,
        FRAME_BINDINGS,
        GDM_TRACE_BINDINGS,
        QUERY_BINDINGS,
        RAY_BOX_FUNCTIONS,
        TRACE_FUNCTIONS,
        QUERY_INDEX_FUNCTIONS,
        QUERY_FUNCTIONS,
        GDM_FUNCTIONS,
        GDM_TRACE_FUNCTIONS,
        GDM_TRACE_RAYS,
    ])
}

/// The inverse-geometric-texture pass (kinds/igt.rs); with `surface`, the module of the surface
/// pass too (its fragment entry point `fs_surface` beside the scene pass's).
pub fn igt_raster(surface: bool) -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        IGT_TYPES,
        TARGETS_TYPES,
        FRAME_BINDINGS,
        IGT_BINDINGS,
        CAMERA_FUNCTIONS,
        RAY_TRIANGLE_FUNCTIONS,
        IGT_FUNCTIONS,
        IGT_RASTER,
        if surface { IGT_SURFACE } else { "" },
    ])
}

/// The depth copy pass (targets.rs).
pub fn depth_copy() -> String {
    assemble(&[DEPTH_COPY_BINDINGS, DEPTH_COPY])
}

/// The surfel passes that run before the scene pass (kinds/surfels.rs).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SurfelPass {
    Cull,
    Args,
    /// One pass with 64-bit atomics.
    Splat64,
    /// The 32-bit fallback's two passes.
    SplatDepth32,
    SplatId32,
}

/// A surfel compute pass's module: the frame's group 0, the kind's group 1 and as group 2 the
/// splat passes' visibility buffer (of their atomics' width) or the arguments pass's output.
pub fn surfels_compute(pass: SurfelPass) -> String {
    let (visibility, entry) = match pass {
        SurfelPass::Cull => ("", SURFELS_CULL),
        SurfelPass::Args => (SURFELS_ARGS_BINDINGS, SURFELS_ARGS),
        SurfelPass::Splat64 => (SURFELS_VIS64_BINDINGS, SURFELS_SPLAT64),
        SurfelPass::SplatDepth32 => (SURFELS_VIS32_BINDINGS, SURFELS_SPLAT_DEPTH32),
        SurfelPass::SplatId32 => (SURFELS_VIS32_BINDINGS, SURFELS_SPLAT_ID32),
    };
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        SURFELS_TYPES,
        FRAME_BINDINGS,
        SURFELS_BINDINGS,
        visibility,
        CAMERA_FUNCTIONS,
        SURFELS_FUNCTIONS,
        SURFELS_CLIP_FUNCTIONS,
        entry,
    ])
}

/// The surfel resolve pass, drawn in the scene pass (kinds/surfels.rs).
pub fn surfels_resolve() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        SURFELS_TYPES,
        TARGETS_TYPES,
        FRAME_BINDINGS,
        SURFELS_RESOLVE_BINDINGS,
        CAMERA_FUNCTIONS,
        SURFELS_FUNCTIONS,
        SURFELS_RESOLVE,
    ])
}

/// Every assembled pipeline module, by name.
pub fn all() -> [(&'static str, String); 18] {
    [
        ("igt_raster", igt_raster(false)),
        ("igt_surface", igt_raster(true)),
        ("gdm_raster", gdm_raster()),
        ("gdm_trace_rays", gdm_trace_rays()),
        ("gtex_raycast", gtex_raycast()),
        ("gtex_tiles", gtex_tiles()),
        ("gtex_tiles_rays", gtex_tiles_rays()),
        ("gtex_trace_rays", gtex_trace_rays()),
        ("mesh_trace_rays", mesh_trace_rays()),
        ("mesh_tiles_rays", mesh_tiles_rays()),
        ("mesh_raster", mesh_raster()),
        ("depth_copy", depth_copy()),
        ("surfels_cull", surfels_compute(SurfelPass::Cull)),
        ("surfels_args", surfels_compute(SurfelPass::Args)),
        ("surfels_splat64", surfels_compute(SurfelPass::Splat64)),
        (
            "surfels_splat_depth32",
            surfels_compute(SurfelPass::SplatDepth32),
        ),
        ("surfels_splat_id32", surfels_compute(SurfelPass::SplatId32)),
        ("surfels_resolve", surfels_resolve()),
    ]
}

#[cfg(test)]
mod tests {
    /// Every pipeline's shader parses and validates with naga (no GPU needed).
    #[test]
    fn every_shader_validates_with_naga() {
        for (name, src) in super::all() {
            let module = naga::front::wgsl::parse_str(&src)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&src)));
            // Only the 64-bit splat pass needs more than the defaults; the renderer builds it
            // only where the adapter has these features (the 32-bit passes elsewhere).
            let capabilities = if name == "surfels_splat64" {
                naga::valid::Capabilities::SHADER_INT64
                    | naga::valid::Capabilities::SHADER_INT64_ATOMIC_MIN_MAX
            } else {
                naga::valid::Capabilities::default()
            };
            naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
                .validate(&module)
                .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
    }

    /// No ray tracer (the compute modules of ray queries and shadow passes, `*_rays`) reads a
    /// uniform buffer. Lavapipe (Mesa 22.3) inlines the values of uniforms that bound a compute
    /// shader's loops and compiles the shader again each time such a buffer is bound anew: every
    /// ray query and shadow pass did (about 0.6 s a call with no shader cache, 8 ms reading it
    /// back from the cache), when the frame's search settings were a uniform. Their settings are
    /// read-only storage buffers instead, which it does not inline. The surfel compute passes read
    /// the camera and their object's uniforms but steer no loop by them: no compilation per frame
    /// (moving camera, no shader cache: 18-23 ms frames).
    #[test]
    fn no_ray_tracer_reads_a_uniform() {
        let tracers = super::all()
            .into_iter()
            .filter(|(name, _)| name.ends_with("_rays"));
        let mut checked = 0;
        for (name, src) in tracers {
            let module = naga::front::wgsl::parse_str(&src).unwrap();
            let info = naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap();
            for (k, entry) in module.entry_points.iter().enumerate() {
                let uses = info.get_entry_point(k);
                let read: Vec<&str> = (module.global_variables.iter())
                    .filter(|(handle, var)| {
                        var.space == naga::AddressSpace::Uniform && !uses[*handle].is_empty()
                    })
                    .map(|(_, var)| var.name.as_deref().unwrap_or("?"))
                    .collect();
                assert!(
                    read.is_empty(),
                    "{name}: {} reads uniforms {read:?}",
                    entry.name
                );
                checked += 1;
            }
        }
        assert_eq!(
            checked, 5,
            "gdm, gtex tiles, gtex, mesh tiles and mesh tracers"
        );
    }

    /// No file in shaders/ is left out of every pipeline.
    #[test]
    fn every_shader_file_is_assembled() {
        let modules = super::all().map(|(_, src)| src);
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/shaders");
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            let used = modules.iter().any(|m| m.contains(&text));
            assert!(used, "{} is in no pipeline's module", path.display());
        }
    }

    /// Each group's bindings are declared in one file, so no assembled module declares one twice.
    #[test]
    fn every_binding_is_declared_once_per_module() {
        for (name, src) in super::all() {
            let mut seen = std::collections::HashSet::new();
            for line in src
                .lines()
                .filter(|l| l.trim_start().starts_with("@group("))
            {
                let key: String = line.split(" var").next().unwrap_or(line).to_string();
                assert!(seen.insert(key.clone()), "{name}: {key} declared twice");
            }
        }
    }
}
