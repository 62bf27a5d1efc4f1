//! WGSL sources, assembled from `shaders/`: WGSL has no #include, so each pipeline's module is
//! the shared camera functions followed by the pipeline's own file.

pub const CAMERA_FUNCTIONS: &str = include_str!("../../shaders/camera_functions.wgsl");
pub const HEIGHTFIELD_FUNCTIONS: &str = include_str!("../../shaders/heightfield_functions.wgsl");
pub const GTEX_RAYCAST: &str = include_str!("../../shaders/gtex_raycast.wgsl");
pub const MESH_RASTER: &str = include_str!("../../shaders/mesh_raster.wgsl");
pub const DEPTH_COPY: &str = include_str!("../../shaders/depth_copy.wgsl");

pub fn gtex_raycast() -> String {
    format!("{CAMERA_FUNCTIONS}\n{HEIGHTFIELD_FUNCTIONS}\n{GTEX_RAYCAST}")
}

pub fn mesh_raster() -> String {
    format!("{CAMERA_FUNCTIONS}\n{MESH_RASTER}")
}

pub fn depth_copy() -> String {
    DEPTH_COPY.to_string()
}

#[cfg(test)]
mod tests {
    /// Every pipeline's shader parses and validates with naga (no GPU needed).
    #[test]
    fn every_shader_validates_with_naga() {
        for (name, src) in [
            ("gtex_raycast", super::gtex_raycast()),
            ("mesh_raster", super::mesh_raster()),
            ("depth_copy", super::depth_copy()),
        ] {
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
}
