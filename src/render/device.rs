//! Headless wgpu device: adapter choice (high performance first, `WGPU_BACKEND` and an
//! adapter-name override honoured), a clear error when there is none, and error scopes that turn
//! GPU errors into `GeomtexError::Device`.
//!
//! Spaces: none.

use crate::error::{GeomtexError, Result};

/// Environment variables naming the adapter to use (a case-insensitive substring of its name).
pub const ADAPTER_ENV: [&str; 2] = ["GEOMTEX_ADAPTER", "WGPU_ADAPTER_NAME"];

const NO_ADAPTER_HELP: &str = "no GPU adapter found. geomtex renders through Vulkan, Metal, DX12 \
or GL; on a machine without a GPU install Mesa's software Vulkan driver (lavapipe): \
`apt-get install mesa-vulkan-drivers libvulkan1` on Debian/Ubuntu";

/// Set to 1 to leave 64-bit atomics unused (surfels then splat in two 32-bit passes).
pub const NO_INT64_ENV: &str = "GEOMTEX_NO_INT64_ATOMICS";

/// The 64-bit atomics the surfel splat pass uses (kinds/surfels.rs).
const INT64_ATOMICS: wgpu::Features =
    wgpu::Features::SHADER_INT64.union(wgpu::Features::SHADER_INT64_ATOMIC_MIN_MAX);

pub struct Gpu {
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub timestamps: bool,
    /// Whether the device has 64-bit atomicMin/Max (requested wherever the adapter offers
    /// them, unless NO_INT64_ENV is 1).
    pub int64_atomics: bool,
}

impl Gpu {
    pub fn new() -> Result<Gpu> {
        pollster::block_on(Self::new_async())
    }

    async fn new_async() -> Result<Gpu> {
        // Honours WGPU_BACKEND (and the other WGPU_* instance variables).
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let wanted = ADAPTER_ENV
            .iter()
            .find_map(|k| std::env::var(k).ok())
            .filter(|s| !s.is_empty());
        let adapter = match wanted {
            Some(name) => {
                let all = instance.enumerate_adapters(wgpu::Backends::all()).await;
                let names: Vec<String> = all
                    .iter()
                    .map(|a| format!("{} ({:?})", a.get_info().name, a.get_info().backend))
                    .collect();
                all.into_iter()
                    .find(|a| {
                        a.get_info()
                            .name
                            .to_lowercase()
                            .contains(&name.to_lowercase())
                    })
                    .ok_or_else(|| {
                        GeomtexError::Device(format!(
                            "no adapter's name contains {name:?} (from {}); available: {}",
                            ADAPTER_ENV.join(" or "),
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        ))
                    })?
            }
            None => instance
                .request_adapter(&wgpu::RequestAdapterOptions {
                    // Without this a machine with a GPU and lavapipe may pick the CPU adapter.
                    power_preference: wgpu::PowerPreference::HighPerformance,
                    force_fallback_adapter: false,
                    compatible_surface: None,
                    apply_limit_buckets: false,
                })
                .await
                .map_err(|e| GeomtexError::Device(format!("{NO_ADAPTER_HELP} ({e})")))?,
        };
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let int64_atomics = adapter.features().contains(INT64_ATOMICS)
            && std::env::var(NO_INT64_ENV).map_or(true, |v| v != "1");
        let mut features = wgpu::Features::empty();
        if timestamps {
            features |= wgpu::Features::TIMESTAMP_QUERY;
        }
        if int64_atomics {
            features |= INT64_ATOMICS;
        }
        let (device, queue) = adapter
            .request_device(&wgpu::DeviceDescriptor {
                label: Some("geomtex"),
                required_features: features,
                required_limits: adapter.limits(),
                experimental_features: wgpu::ExperimentalFeatures::default(),
                memory_hints: wgpu::MemoryHints::Performance,
                trace: wgpu::Trace::Off,
            })
            .await
            .map_err(|e| GeomtexError::Device(format!("the adapter refused a device: {e}")))?;
        // Errors outside an error scope are reported, not turned into a panic across the FFI.
        device.on_uncaptured_error(std::sync::Arc::new(|e| {
            eprintln!("geomtex: uncaptured GPU error: {e}")
        }));
        Ok(Gpu {
            adapter,
            device,
            queue,
            timestamps,
            int64_atomics,
        })
    }

    /// Adapter name, backend, device type and driver, for users and bug reports.
    pub fn info(&self) -> Vec<(&'static str, String)> {
        let i = self.adapter.get_info();
        vec![
            ("name", i.name),
            ("backend", format!("{:?}", i.backend)),
            ("device_type", format!("{:?}", i.device_type)),
            ("driver", i.driver),
            ("driver_info", i.driver_info),
            ("int64_atomics", self.int64_atomics.to_string()),
        ]
    }
}

/// Runs `work` inside validation and out-of-memory error scopes and turns what they catch into
/// `GeomtexError::Device`, so a GPU error never becomes a panic.
pub(crate) fn guarded<T>(device: &wgpu::Device, work: impl FnOnce() -> Result<T>) -> Result<T> {
    let validation = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let memory = device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
    let result = work();
    let oom = pollster::block_on(memory.pop());
    let invalid = pollster::block_on(validation.pop());
    match (oom, invalid) {
        (Some(e), _) => Err(GeomtexError::Device(format!(
            "the GPU ran out of memory: {e}"
        ))),
        (None, Some(e)) => Err(GeomtexError::Device(format!(
            "the GPU rejected a command: {e}"
        ))),
        (None, None) => result,
    }
}

/// A 2D (array) texture with one mip level and one sample, the only kind the renderer makes.
pub(crate) fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    size: wgpu::Extent3d,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size,
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}
