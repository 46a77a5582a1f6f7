//! Adapter selection and the device: a real GPU first, a software one
//! (Mesa's lavapipe) if that is all there is.

use super::GpuError;

/// The adapter `GpuRenderer::new` would use.
fn adapter() -> Result<wgpu::Adapter, GpuError> {
    adapter_of(&instance()).map_err(|e| GpuError::NoAdapter(e.to_string()))
}

/// The instance every device of the backend is made from.
fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
    // Vulkan, Metal or DX12 unless WGPU_BACKEND says otherwise: probing
    // OpenGL would only print EGL noise on headless machines.
    desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
    wgpu::Instance::new(desc)
}

/// The high-performance adapter of `instance`.
fn adapter_of(instance: &wgpu::Instance) -> Result<wgpu::Adapter, wgpu::RequestAdapterError> {
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
}

/// What adapter there is, without creating a device: `Ok((name, software))`
/// where `software` means a CPU implementation such as lavapipe (slower
/// than the CPU backend; `--backend auto` does not pick it).
pub fn probe() -> Result<(String, bool), GpuError> {
    let info = adapter()?.get_info();
    Ok((info.name, info.device_type == wgpu::DeviceType::Cpu))
}

/// A device on the chosen adapter, with what the renderer needs to know of it.
pub(super) struct Opened {
    /// The instance and adapter the device was made on: a window that
    /// presents the frames on this device makes its surface from them.
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// The adapter in words (name, backend, type, driver).
    pub name: String,
    /// The adapter reports `TIMESTAMP_QUERY` (and the device was created
    /// with it).
    pub timestamps: bool,
    /// `max_storage_buffer_binding_size` of the adapter (bytes).
    pub max_binding: u64,
}

/// Opens a device with the adapter's own limits and, where it has them,
/// timestamp queries.
pub(super) fn open() -> Result<Opened, GpuError> {
    let instance = instance();
    let adapter = adapter_of(&instance).map_err(|e| GpuError::NoAdapter(e.to_string()))?;
    let info = adapter.get_info();
    let name = adapter_name(&info);
    let limits = adapter.limits();
    let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("gazecast"),
        required_limits: limits.clone(),
        required_features: if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        },
        ..Default::default()
    }))
    .map_err(|e| GpuError::Device(e.to_string()))?;
    Ok(Opened {
        instance,
        adapter,
        device,
        queue,
        name,
        timestamps,
        max_binding: limits.max_storage_buffer_binding_size,
    })
}

/// The adapter in words (name, backend, type, driver).
fn adapter_name(info: &wgpu::AdapterInfo) -> String {
    format!(
        "{} ({:?}, {:?}, driver {} {})",
        info.name, info.backend, info.device_type, info.driver, info.driver_info
    )
}

impl Opened {
    /// What the renderer needs to know of a device already open.
    pub(super) fn of(shared: &super::SharedDevice) -> Self {
        let info = shared.adapter.get_info();
        Self {
            instance: shared.instance.clone(),
            adapter: shared.adapter.clone(),
            device: shared.device.clone(),
            queue: shared.queue.clone(),
            name: adapter_name(&info),
            timestamps: shared
                .device
                .features()
                .contains(wgpu::Features::TIMESTAMP_QUERY),
            max_binding: shared.device.limits().max_storage_buffer_binding_size,
        }
    }
}

/// A device on the adapter `GpuRenderer::new` would choose, opened as it
/// would open it (the adapter's limits, timestamp queries where it has
/// them), for renderers made on it in turn ([`super::GpuRenderer::on_device`])
/// and a window that presents their frames.
pub fn open_shared() -> Result<super::SharedDevice, GpuError> {
    let o = open()?;
    Ok(super::SharedDevice {
        instance: o.instance,
        adapter: o.adapter,
        device: o.device,
        queue: o.queue,
        traffic: Default::default(),
    })
}

/// A device of its own, on the adapter `GpuRenderer::new` would choose,
/// for compute work on buffers that do not come from a cast (the attention
/// model on a frame rendered elsewhere, its tests and benchmarks).
pub struct GpuDevice {
    /// The device.
    pub device: wgpu::Device,
    /// The device's queue.
    pub queue: wgpu::Queue,
    /// The adapter in words (name, backend, type, driver).
    pub adapter: String,
    /// `max_storage_buffer_binding_size` of the adapter (bytes).
    pub max_binding: u64,
    /// The bytes and calls its users move through it (they upload, read
    /// back, dispatch and submit through this counter).
    pub traffic: std::sync::Arc<super::TrafficCounter>,
}

/// Opens a [`GpuDevice`] (no timestamp queries).
pub fn open_device() -> Result<GpuDevice, GpuError> {
    let opened = open()?;
    Ok(GpuDevice {
        device: opened.device,
        queue: opened.queue,
        adapter: opened.name,
        max_binding: opened.max_binding,
        traffic: Default::default(),
    })
}
