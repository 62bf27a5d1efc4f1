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

/// Devices made in this process: one is what a process needs (the binding shares one renderer).
static DEVICES_MADE: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

pub fn devices_made() -> u64 {
    DEVICES_MADE.load(std::sync::atomic::Ordering::Relaxed)
}

impl Gpu {
    pub fn new() -> Result<Gpu> {
        let gpu = pollster::block_on(Self::new_async())?;
        DEVICES_MADE.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Ok(gpu)
    }

    async fn new_async() -> Result<Gpu> {
        // Honours WGPU_BACKEND (and the other WGPU_* instance variables).
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = choose_adapter(&instance).await?;
        refuse_unsupported(&adapter)?;
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

    /// Adapter name, backend, device type and driver, the optional features in use and the
    /// limits that bind, for users and bug reports.
    pub fn info(&self) -> Vec<(&'static str, String)> {
        let i = self.adapter.get_info();
        let limits = self.device.limits();
        vec![
            ("name", i.name),
            ("backend", format!("{:?}", i.backend)),
            ("device_type", format!("{:?}", i.device_type)),
            ("driver", i.driver),
            ("driver_info", i.driver_info),
            ("int64_atomics", self.int64_atomics.to_string()),
            ("timestamps", self.timestamps.to_string()),
            (
                "max_texture_dimension_2d",
                limits.max_texture_dimension_2d.to_string(),
            ),
            (
                "max_storage_buffer_binding_size",
                limits.max_storage_buffer_binding_size.to_string(),
            ),
            ("max_buffer_size", limits.max_buffer_size.to_string()),
        ]
    }
}

/// Where an adapter stands in the choice: primary backends (Vulkan, Metal, DX12) before the
/// others, then real GPUs before virtual and software ones.
fn preference(info: &wgpu::AdapterInfo) -> (bool, u8) {
    let primary = wgpu::Backends::PRIMARY.contains(wgpu::Backends::from(info.backend));
    let kind = match info.device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    (!primary, kind)
}

fn describe(info: &wgpu::AdapterInfo) -> String {
    format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type)
}

/// The adapter named by ADAPTER_ENV, else the most preferred one the instance offers. Chosen from
/// the list on purpose: `request_adapter` alone took llvmpipe through OpenGL on a machine with
/// no Vulkan driver, and texture sets came back blank there.
async fn choose_adapter(instance: &wgpu::Instance) -> Result<wgpu::Adapter> {
    let mut all = instance.enumerate_adapters(wgpu::Backends::all()).await;
    all.sort_by_key(|a| preference(&a.get_info()));
    let names: Vec<String> = all.iter().map(|a| describe(&a.get_info())).collect();
    let available = if names.is_empty() {
        "none".to_string()
    } else {
        names.join(", ")
    };
    let wanted = ADAPTER_ENV
        .iter()
        .find_map(|k| std::env::var(k).ok())
        .filter(|s| !s.is_empty());
    match wanted {
        Some(name) => all
            .into_iter()
            .find(|a| {
                a.get_info()
                    .name
                    .to_lowercase()
                    .contains(&name.to_lowercase())
            })
            .ok_or_else(|| {
                GeomtexError::Device(format!(
                    "no adapter's name contains {name:?} (from {}); available: {available}",
                    ADAPTER_ENV.join(" or ")
                ))
            }),
        None => all.into_iter().next().ok_or_else(|| {
            GeomtexError::Device(format!(
                "{NO_ADAPTER_HELP} (WGPU_BACKEND={})",
                std::env::var("WGPU_BACKEND").unwrap_or_else(|_| "unset".into())
            ))
        }),
    }
}

/// Refuses an adapter on which some object kind would draw wrong: the GL backend (texture sets
/// came back blank and ray queries and shadow rays missed everything there, while meshes,
/// surfels, IGT and GDM shells passed gt.info()'s self-check on Mesa's llvmpipe), and
/// any adapter short of the WebGPU baseline the passes are written for (compute shaders,
/// storage buffers and textures, independent blending, the default limits).
fn refuse_unsupported(adapter: &wgpu::Adapter) -> Result<()> {
    let info = adapter.get_info();
    let fix = format!(
        "install a Vulkan driver (on Debian/Ubuntu Mesa's software one: `apt-get install \
         mesa-vulkan-drivers libvulkan1`), or name a Vulkan, Metal or DX12 adapter in {}; \
         unset WGPU_BACKEND if it asks for gl",
        ADAPTER_ENV[0]
    );
    if info.backend == wgpu::Backend::Gl {
        return Err(GeomtexError::Device(format!(
            "the adapter found is {}, through OpenGL, where geomtex draws wrong: texture sets \
             come back blank and ray queries and shadow rays miss everything (meshes, surfels, \
             IGT and GDM shells do draw there); {fix}",
            describe(&info)
        )));
    }
    let downlevel = adapter.get_downlevel_capabilities();
    let mut short = Vec::new();
    if !downlevel.is_webgpu_compliant() {
        short.push(format!(
            "missing capabilities {:?}",
            wgpu::DownlevelFlags::compliant() - downlevel.flags
        ));
    }
    wgpu::Limits::default().check_limits_with_fail_fn(
        &adapter.limits(),
        false,
        |name, needs, has| short.push(format!("{name} is {has}, below the {needs} needed")),
    );
    if short.is_empty() {
        Ok(())
    } else {
        Err(GeomtexError::Device(format!(
            "the adapter {} cannot run geomtex's passes: {}; {fix}",
            describe(&info),
            short.join("; ")
        )))
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
