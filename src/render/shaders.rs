//! WGSL sources, assembled from `shaders/`. WGSL has no #include, so each pipeline's module is its
//! files concatenated in one order: types, then bindings, then functions, then the pass's entry
//! points. Each bind group's bindings are declared in exactly one `*_bindings.wgsl` file.

macro_rules! shader {
    ($file:literal) => {
        include_str!(concat!("../../shaders/", $file))
    };
}

const CAMERA_TYPES: &str = shader!("camera_types.wgsl");
const SEARCH_TYPES: &str = shader!("search_types.wgsl");
const GTEX_TYPES: &str = shader!("gtex_types.wgsl");
const MESH_TYPES: &str = shader!("mesh_types.wgsl");
const TRACE_TYPES: &str = shader!("trace_types.wgsl");
const QUERY_TYPES: &str = shader!("query_types.wgsl");

const FRAME_BINDINGS: &str = shader!("frame_bindings.wgsl");
const GTEX_BINDINGS: &str = shader!("gtex_bindings.wgsl");
const MESH_BINDINGS: &str = shader!("mesh_bindings.wgsl");
const QUERY_BINDINGS: &str = shader!("query_bindings.wgsl");
const GTEX_TRACE_BINDINGS: &str = shader!("gtex_trace_bindings.wgsl");
const MESH_TRACE_BINDINGS: &str = shader!("mesh_trace_bindings.wgsl");
const DEPTH_COPY_BINDINGS: &str = shader!("depth_copy_bindings.wgsl");

const CAMERA_FUNCTIONS: &str = shader!("camera_functions.wgsl");
const HEIGHTFIELD_FUNCTIONS: &str = shader!("heightfield_functions.wgsl");
const GTEX_PIECE_FUNCTIONS: &str = shader!("gtex_piece_functions.wgsl");
const RAY_BOX_FUNCTIONS: &str = shader!("ray_box_functions.wgsl");
const TRACE_FUNCTIONS: &str = shader!("trace_functions.wgsl");
const GTEX_TRACE_FUNCTIONS: &str = shader!("gtex_trace_functions.wgsl");
const MESH_TRACE_FUNCTIONS: &str = shader!("mesh_trace_functions.wgsl");

const GTEX_RAYCAST: &str = shader!("gtex_raycast.wgsl");
const GTEX_TRACE_RAYS: &str = shader!("gtex_trace_rays.wgsl");
const MESH_TRACE_RAYS: &str = shader!("mesh_trace_rays.wgsl");
const MESH_RASTER: &str = shader!("mesh_raster.wgsl");
const DEPTH_COPY: &str = shader!("depth_copy.wgsl");

fn assemble(parts: &[&str]) -> String {
    parts.join("\n")
}

/// The geometry-texture raster pass (kinds/gtex).
pub fn gtex_raycast() -> String {
    assemble(&[
        CAMERA_TYPES,
        SEARCH_TYPES,
        GTEX_TYPES,
        FRAME_BINDINGS,
        GTEX_BINDINGS,
        CAMERA_FUNCTIONS,
        HEIGHTFIELD_FUNCTIONS,
        RAY_BOX_FUNCTIONS,
        GTEX_PIECE_FUNCTIONS,
        GTEX_RAYCAST,
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
        GTEX_TRACE_BINDINGS,
        QUERY_BINDINGS,
        HEIGHTFIELD_FUNCTIONS,
        RAY_BOX_FUNCTIONS,
        GTEX_PIECE_FUNCTIONS,
        TRACE_FUNCTIONS,
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
        MESH_TRACE_FUNCTIONS,
        MESH_TRACE_RAYS,
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
        FRAME_BINDINGS,
        MESH_BINDINGS,
        CAMERA_FUNCTIONS,
        MESH_RASTER,
    ])
}

/// The depth copy pass (targets.rs).
pub fn depth_copy() -> String {
    assemble(&[DEPTH_COPY_BINDINGS, DEPTH_COPY])
}

/// Every assembled pipeline module, by name.
pub fn all() -> [(&'static str, String); 5] {
    [
        ("gtex_raycast", gtex_raycast()),
        ("gtex_trace_rays", gtex_trace_rays()),
        ("mesh_trace_rays", mesh_trace_rays()),
        ("mesh_raster", mesh_raster()),
        ("depth_copy", depth_copy()),
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
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::default(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {e:?}"));
        }
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
