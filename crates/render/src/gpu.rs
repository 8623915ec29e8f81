//! Opening a GPU: instance, adapter, device and queue, with errors that say what to install.

/// Why no GPU could be used.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter at all, not even a software one.
    #[error(
        "no GPU adapter found ({0}). Install a Vulkan driver; with no GPU, a software one works: \
         on Debian/Ubuntu `apt install mesa-vulkan-drivers` (lavapipe)"
    )]
    NoAdapter(String),
    /// The adapter refused to open a device with what the renderer needs.
    #[error("could not open a device on adapter `{adapter}`: {why}")]
    NoDevice {
        /// The adapter's name.
        adapter: String,
        /// Why.
        why: String,
    },
    /// The window surface could not be created.
    #[error("could not create a window surface: {0}")]
    Surface(String),
}

/// An opened GPU: what every renderer call needs.
#[derive(Debug)]
pub struct Gpu {
    /// The wgpu instance.
    pub instance: wgpu::Instance,
    /// The adapter in use.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A wgpu instance honouring `WGPU_BACKEND` and friends.
    pub fn new_instance() -> wgpu::Instance {
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
    }

    /// Opens a GPU for offscreen rendering (tests, `shoal render`, benchmarks).
    ///
    /// Tries the native backends (Vulkan, Metal, DX12) first, then every backend (GL), unless
    /// `WGPU_BACKEND` chooses.
    pub fn headless() -> Result<Self, GpuError> {
        let options = wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        };
        let mut last_error = String::new();
        let from_env = std::env::var_os("WGPU_BACKEND").is_some();
        let tries: &[Option<wgpu::Backends>] = if from_env {
            &[None]
        } else {
            &[Some(wgpu::Backends::PRIMARY), None]
        };
        for backends in tries {
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
            if let Some(b) = backends {
                desc.backends = *b;
            }
            let instance = wgpu::Instance::new(desc);
            match pollster::block_on(instance.request_adapter(&options)) {
                Ok(adapter) => return Self::open(instance, adapter),
                Err(e) => last_error = e.to_string(),
            }
        }
        Err(GpuError::NoAdapter(last_error))
    }

    /// Opens a device on `adapter`.
    pub fn open(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Self, GpuError> {
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("shoal device"),
            required_features: wgpu::Features::empty(),
            required_limits: adapter.limits(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| GpuError::NoDevice {
            adapter: info.name.clone(),
            why: e.to_string(),
        })?;
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// One line naming the adapter, its backend and driver, e.g. for `shoal render` to print.
    pub fn adapter_summary(&self) -> String {
        let info = self.adapter.get_info();
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            info.name, info.backend, info.device_type, info.driver, info.driver_info
        )
    }

    /// Waits until the GPU has finished all submitted work.
    pub fn wait_idle(&self) {
        // A poll error means the device was lost; later calls report it.
        let _ = self.device.poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        });
    }
}
