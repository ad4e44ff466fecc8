//! The GPU device: a Vulkan adapter found headless, and its queue.

/// What can go wrong on the GPU.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    /// No adapter: there is no Vulkan driver.
    #[error(
        "no GPU adapter found: isoray's GPU backend needs a Vulkan driver; for a software one install \
         Mesa's lavapipe (Debian/Ubuntu: `apt-get install mesa-vulkan-drivers libvulkan1`)"
    )]
    NoAdapter,
    /// The adapter refused a device.
    #[error("the GPU adapter `{adapter}` gave no device: {message}")]
    Device {
        /// The adapter's name.
        adapter: String,
        /// What wgpu said.
        message: String,
    },
    /// A shader did not compile, or a pass failed.
    #[error("GPU: {0}")]
    Gpu(String),
    /// The render was cancelled.
    #[error("cancelled")]
    Cancelled,
}

/// Storage buffers the tracer binds in one shader.
const STORAGE_BUFFERS: u32 = 13;

/// A GPU device and its queue, with the adapter's description.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
}

impl std::fmt::Debug for Gpu {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Gpu").field("adapter", &self.adapter_name()).finish()
    }
}

impl Gpu {
    /// The first Vulkan adapter (a real GPU before a software one), headless.
    pub fn new() -> Result<Gpu, GpuError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::VULKAN;
        desc.flags = wgpu::InstanceFlags::empty();
        let instance = wgpu::Instance::new(desc);
        let mut adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
        // A real GPU first: discrete, integrated, then anything else (lavapipe is a CPU).
        adapters.sort_by_key(|a| match a.get_info().device_type {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            _ => 3,
        });
        let adapter = adapters.into_iter().next().ok_or(GpuError::NoAdapter)?;
        let info = adapter.get_info();
        // Timestamp queries time the passes where the adapter has them.
        let features = adapter.features() & wgpu::Features::TIMESTAMP_QUERY;
        // The tracer binds thirteen storage buffers (WebGPU's default allows 8;
        // every Vulkan driver has more).
        let have = adapter.limits();
        if have.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return Err(GpuError::Device {
                adapter: info.name.clone(),
                message: format!(
                    "it binds {} storage buffers per shader, isoray's tracer needs {STORAGE_BUFFERS}",
                    have.max_storage_buffers_per_shader_stage
                ),
            });
        }
        let limits = wgpu::Limits {
            max_storage_buffers_per_shader_stage: STORAGE_BUFFERS,
            max_storage_buffer_binding_size: have.max_storage_buffer_binding_size,
            max_buffer_size: have.max_buffer_size,
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("isoray"),
            required_features: features,
            required_limits: limits,
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device {
            adapter: info.name.clone(),
            message: e.to_string(),
        })?;
        Ok(Gpu { device, queue, info })
    }

    /// The adapter, as the summary line names it: `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub fn adapter_name(&self) -> String {
        if self.info.driver_info.is_empty() {
            self.info.name.clone()
        } else {
            format!("{} ({})", self.info.name, self.info.driver_info)
        }
    }

    /// Compiles `source` (WGSL, entry point `main`) into a compute pipeline
    /// whose one bind group holds buffers of the given binding types, in
    /// binding order. A shader that does not compile is an error naming `what`.
    pub(crate) fn compute_pipeline(
        &self,
        source: &str,
        what: &str,
        bindings: &[wgpu::BufferBindingType],
    ) -> Result<(wgpu::ComputePipeline, wgpu::BindGroupLayout), GpuError> {
        let (mut pipelines, layout) = self.compute_pipelines(source, what, bindings, &["main"])?;
        Ok((pipelines.remove(0), layout))
    }

    /// Whether the adapter is a software one (lavapipe, llvmpipe,
    /// SwiftShader, WARP): the CPU's cores running the shaders.
    pub fn is_software(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// As [`Gpu::compute_pipeline`], one pipeline per entry point of the
    /// module, all with the same bind group layout.
    pub(crate) fn compute_pipelines(
        &self,
        source: &str,
        what: &str,
        bindings: &[wgpu::BufferBindingType],
        entry_points: &[&str],
    ) -> Result<(Vec<wgpu::ComputePipeline>, wgpu::BindGroupLayout), GpuError> {
        let device = &self.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some(what),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let entries: Vec<wgpu::BindGroupLayoutEntry> = bindings
            .iter()
            .enumerate()
            .map(|(binding, &ty)| wgpu::BindGroupLayoutEntry {
                binding: binding as u32,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(what),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some(what),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipelines = entry_points
            .iter()
            .map(|&entry| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(what),
                    layout: Some(&pipeline_layout),
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    cache: None,
                })
            })
            .collect();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Gpu(format!("the shader of {what} did not compile: {e}")));
        }
        Ok((pipelines, layout))
    }

    /// Waits for `submission`, then reads the mapped-readable `buffer` as words.
    pub(crate) fn read_back(
        &self,
        buffer: &wgpu::Buffer,
        submission: wgpu::SubmissionIndex,
    ) -> Result<Vec<u32>, GpuError> {
        let slice = buffer.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| {});
        self.wait(submission)?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| GpuError::Gpu(format!("reading results back: {e}")))?;
        Ok(view
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect())
    }

    /// Waits until the GPU has finished `submission`.
    pub(crate) fn wait(&self, submission: wgpu::SubmissionIndex) -> Result<(), GpuError> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(submission),
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| GpuError::Gpu(format!("waiting for the GPU: {e}")))
    }
}
