//! Every wgpu call of the crate, in one place, so that a wgpu upgrade touches only this file
//! (written against wgpu 30: `InstanceDescriptor::new_without_display_handle_from_env`,
//! `enumerate_adapters` returning a future, `on_uncaptured_error` taking an `Arc`, error scopes
//! popped through a guard, `PollType::Wait` with a submission index and a timeout).
//!
//! The process-wide instance, adapter enumeration and selection, device creation (with an error
//! handler that records validation errors and device loss instead of panicking), compute
//! pipelines from WGSL with an explicit bind-group layout, buffers, one-dispatch submissions
//! with optional timestamp queries, and blocking readback.

use std::sync::{mpsc, Arc, Mutex, OnceLock};

/// Buffers, bind groups and pipelines are wgpu's own handles.
pub use wgpu::{BindGroup, BindGroupLayout, Buffer, ComputePipeline, SubmissionIndex};

/// Backends searched: the native compute APIs (Vulkan, Metal, DX12); GL is not used.
fn backends() -> wgpu::Backends {
    wgpu::Backends::VULKAN | wgpu::Backends::METAL | wgpu::Backends::DX12
}

/// The one wgpu instance of the process, created on first use.
fn instance() -> &'static wgpu::Instance {
    static INSTANCE: OnceLock<wgpu::Instance> = OnceLock::new();
    INSTANCE.get_or_init(|| {
        // Creating a Vulkan instance probes the Wayland client library, which prints
        // "XDG_RUNTIME_DIR is invalid or not set" to stderr once per instance when the variable
        // is missing (headless machines, CI, `sudo`). Nothing here uses a display, so point it at
        // the temporary directory when unset; this runs once, before any Vulkan call of the
        // process, and every instance is created here.
        #[cfg(unix)]
        if std::env::var_os("XDG_RUNTIME_DIR").is_none() {
            std::env::set_var("XDG_RUNTIME_DIR", std::env::temp_dir());
        }
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle_from_env();
        desc.backends &= backends();
        if desc.backends.is_empty() {
            desc.backends = backends();
        }
        wgpu::Instance::new(desc)
    })
}

/// One adapter found on the machine.
pub struct AdapterEntry {
    /// Adapter name, e.g. `llvmpipe (LLVM 15.0.6, 256 bits)`.
    pub name: String,
    /// Backend, e.g. `Vulkan`.
    pub backend: String,
    /// Device type, e.g. `DiscreteGpu`, `Cpu`.
    pub device_type: String,
    /// Whether it is a software rasteriser on the CPU (lavapipe, WARP, SwiftShader).
    pub is_cpu: bool,
    /// Driver name and driver info.
    pub driver: String,
    /// Preference: 0 discrete, 1 integrated, 2 virtual, 3 other, 4 CPU.
    pub rank: u8,
    adapter: wgpu::Adapter,
}

impl AdapterEntry {
    /// Whether `other` is the same adapter (name, backend, type and driver).
    pub fn same_as(&self, name: &str, backend: &str, device_type: &str, driver: &str) -> bool {
        self.name == name
            && self.backend == backend
            && self.device_type == device_type
            && self.driver == driver
    }
}

/// All Vulkan / Metal / DX12 adapters, in the order wgpu reports them.
pub fn adapters() -> Vec<AdapterEntry> {
    pollster::block_on(instance().enumerate_adapters(backends()))
        .into_iter()
        .map(|adapter| {
            let info = adapter.get_info();
            AdapterEntry {
                name: info.name.clone(),
                backend: format!("{:?}", info.backend),
                device_type: format!("{:?}", info.device_type),
                is_cpu: info.device_type == wgpu::DeviceType::Cpu,
                driver: driver_string(&info),
                rank: match info.device_type {
                    wgpu::DeviceType::DiscreteGpu => 0,
                    wgpu::DeviceType::IntegratedGpu => 1,
                    wgpu::DeviceType::VirtualGpu => 2,
                    wgpu::DeviceType::Other => 3,
                    wgpu::DeviceType::Cpu => 4,
                },
                adapter,
            }
        })
        .collect()
}

fn driver_string(info: &wgpu::AdapterInfo) -> String {
    match (info.driver.is_empty(), info.driver_info.is_empty()) {
        (true, true) => String::from("unknown driver"),
        (false, true) => info.driver.clone(),
        (true, false) => info.driver_info.clone(),
        (false, false) => format!("{} {}", info.driver, info.driver_info),
    }
}

/// Picks an adapter: by case-insensitive substring of its name if `filter` is given, else the
/// most capable (discrete, integrated, virtual, other, then CPU); `hardware_only` rejects
/// software (CPU) adapters when no filter is given.
pub fn pick_adapter(filter: Option<&str>, hardware_only: bool) -> Result<AdapterEntry, String> {
    let mut list = adapters();
    if list.is_empty() {
        return Err(
            "no Vulkan, Metal or DX12 adapter found (install a GPU driver, or Mesa's \
                    lavapipe for a software Vulkan device)"
                .into(),
        );
    }
    if let Some(f) = filter {
        let names: Vec<String> = list.iter().map(|a| a.name.clone()).collect();
        let needle = f.to_lowercase();
        return match list
            .into_iter()
            .find(|a| a.name.to_lowercase().contains(&needle))
        {
            Some(a) => Ok(a),
            None => Err(format!(
                "no adapter name contains '{f}'; available: {}",
                names.join(", ")
            )),
        };
    }
    list.sort_by_key(|a| a.rank);
    let best = list.remove(0);
    if hardware_only && best.is_cpu {
        return Err(format!(
            "only a software adapter is present ({})",
            best.name
        ));
    }
    Ok(best)
}

/// What a binding of the explicit bind-group layout holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindingKind {
    /// A uniform buffer.
    Uniform,
    /// A read-only storage buffer (`var<storage, read>`).
    StorageRead,
    /// A read-write storage buffer (`var<storage, read_write>`).
    StorageReadWrite,
}

/// An open device with its queue.
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// Adapter name.
    pub name: String,
    /// Backend name.
    pub backend: String,
    /// Device type.
    pub device_type: String,
    /// Driver name and info.
    pub driver: String,
    /// Whether the device was created with timestamp queries (when the adapter has them).
    pub timestamps: bool,
    /// Largest workgroup count in one dispatch dimension.
    pub max_workgroups: u32,
    /// Largest storage-buffer binding, bytes.
    pub max_binding: u64,
    /// Largest buffer, bytes.
    pub max_buffer: u64,
    errors: Arc<Mutex<Vec<String>>>,
}

/// Two timestamps (start and end of a compute pass) and where they are read back.
pub struct Timer {
    set: wgpu::QuerySet,
    resolve: Buffer,
    staging: Buffer,
    period_ns: f64,
}

/// Read-only bytes of a mapped buffer, unmapped on drop.
pub struct Mapped<'a> {
    buffer: &'a Buffer,
    view: Option<wgpu::BufferView>,
}

impl Mapped<'_> {
    /// The bytes.
    pub fn bytes(&self) -> &[u8] {
        match &self.view {
            Some(v) => v,
            None => &[],
        }
    }
}

impl Drop for Mapped<'_> {
    fn drop(&mut self) {
        drop(self.view.take());
        self.buffer.unmap();
    }
}

/// A pending `map_async` of a staging buffer.
pub struct PendingMap {
    rx: mpsc::Receiver<Result<(), wgpu::BufferAsyncError>>,
}

impl Gpu {
    /// Opens a device on `entry`, with timestamp queries if the adapter supports them.
    pub fn open(entry: AdapterEntry) -> Result<Self, String> {
        let adapter = entry.adapter;
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let limits = adapter.limits();
        let desc = wgpu::DeviceDescriptor {
            label: Some("gpu-amcs"),
            required_features: if timestamps {
                wgpu::Features::TIMESTAMP_QUERY
            } else {
                wgpu::Features::empty()
            },
            required_limits: limits.clone(),
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc))
            .map_err(|e| format!("cannot open a device on '{}': {e}", entry.name))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(Gpu {
            device,
            queue,
            name: entry.name,
            backend: entry.backend,
            device_type: entry.device_type,
            driver: entry.driver,
            timestamps,
            max_workgroups: limits.max_compute_workgroups_per_dimension,
            max_binding: limits.max_storage_buffer_binding_size,
            max_buffer: limits.max_buffer_size,
            errors,
        })
    }

    /// The first error the device reported since the last call, if any.
    pub fn take_error(&self) -> Option<String> {
        let mut v = self.errors.lock().ok()?;
        if v.is_empty() {
            None
        } else {
            Some(v.drain(..).collect::<Vec<_>>().join("; "))
        }
    }

    /// Compiles `source` and builds the compute pipeline of `entry` (layout derived from the
    /// shader). Validation errors come back as `Err`.
    pub fn pipeline(
        &self,
        source: &str,
        entry: &str,
    ) -> Result<(ComputePipeline, BindGroupLayout), String> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(entry),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pipeline = self
            .device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("shader '{entry}': {e}"));
        }
        let layout = pipeline.get_bind_group_layout(0);
        Ok((pipeline, layout))
    }

    /// An explicit bind-group layout for compute shaders: `(binding, kind)` per entry.
    pub fn layout(&self, entries: &[(u32, BindingKind)]) -> BindGroupLayout {
        let entries: Vec<wgpu::BindGroupLayoutEntry> = entries
            .iter()
            .map(|&(binding, kind)| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty: match kind {
                        BindingKind::Uniform => wgpu::BufferBindingType::Uniform,
                        BindingKind::StorageRead => {
                            wgpu::BufferBindingType::Storage { read_only: true }
                        }
                        BindingKind::StorageReadWrite => {
                            wgpu::BufferBindingType::Storage { read_only: false }
                        }
                    },
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            })
            .collect();
        self.device
            .create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: None,
                entries: &entries,
            })
    }

    /// Compiles `source` once and builds one compute pipeline per entry point, all with
    /// `layout` as bind group 0, so one bind group serves every entry point. Validation errors
    /// come back as `Err`.
    pub fn pipelines(
        &self,
        source: &str,
        entries: &[&str],
        layout: &BindGroupLayout,
    ) -> Result<Vec<ComputePipeline>, String> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: entries.first().copied(),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        let pl = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: None,
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
        let out = entries
            .iter()
            .map(|entry| {
                self.device
                    .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                        label: Some(entry),
                        layout: Some(&pl),
                        module: &module,
                        entry_point: Some(entry),
                        compilation_options: Default::default(),
                        cache: None,
                    })
            })
            .collect();
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!("shader '{}': {e}", entries.join("', '")));
        }
        Ok(out)
    }

    /// A storage buffer of `size` bytes (copy source, so results can be read back).
    pub fn storage(&self, label: &str, size: u64) -> Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A storage buffer holding `data`.
    pub fn storage_init(&self, label: &str, data: &[u8]) -> Buffer {
        let b = self.storage(label, data.len() as u64);
        if !data.is_empty() {
            self.queue.write_buffer(&b, 0, data);
        }
        b
    }

    /// A uniform buffer of `size` bytes.
    pub fn uniform(&self, label: &str, size: u64) -> Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// A buffer the CPU can map for reading.
    pub fn staging(&self, label: &str, size: u64) -> Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// Writes `data` into `buffer` at offset 0 before the next submission.
    pub fn write(&self, buffer: &Buffer, data: &[u8]) {
        self.queue.write_buffer(buffer, 0, data);
    }

    /// Bind group with each `(binding, buffer)` pair.
    pub fn bind_group(&self, layout: &BindGroupLayout, buffers: &[(u32, &Buffer)]) -> BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|&(binding, b)| wgpu::BindGroupEntry {
                binding,
                resource: b.as_entire_binding(),
            })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout,
            entries: &entries,
        })
    }

    /// A timer for one compute pass, if the device has timestamp queries.
    pub fn timer(&self) -> Option<Timer> {
        if !self.timestamps {
            return None;
        }
        let set = self.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timer"),
            ty: wgpu::QueryType::Timestamp,
            count: 2,
        });
        let resolve = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: 16,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = self.staging("timestamps staging", 16);
        Some(Timer {
            set,
            resolve,
            staging,
            period_ns: f64::from(self.queue.get_timestamp_period()),
        })
    }

    /// Records and submits one dispatch of `groups` workgroups followed by buffer copies
    /// `(src, dst, bytes)`, optionally timing the pass.
    pub fn dispatch(
        &self,
        pipeline: &ComputePipeline,
        bind_group: &BindGroup,
        groups: u32,
        copies: &[(&Buffer, &Buffer, u64)],
        timer: Option<&Timer>,
    ) -> SubmissionIndex {
        let mut enc = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: None,
                timestamp_writes: timer.map(|t| wgpu::ComputePassTimestampWrites {
                    query_set: &t.set,
                    beginning_of_pass_write_index: Some(0),
                    end_of_pass_write_index: Some(1),
                }),
            });
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        for (src, dst, bytes) in copies {
            if *bytes > 0 {
                enc.copy_buffer_to_buffer(src, 0, dst, 0, *bytes);
            }
        }
        if let Some(t) = timer {
            enc.resolve_query_set(&t.set, 0..2, &t.resolve, 0);
            enc.copy_buffer_to_buffer(&t.resolve, 0, &t.staging, 0, 16);
        }
        self.queue.submit(Some(enc.finish()))
    }

    /// Requests a read mapping of the first `bytes` of `buffer` (after the work submitted so
    /// far).
    pub fn map_read(&self, buffer: &Buffer, bytes: u64) -> PendingMap {
        let (tx, rx) = mpsc::channel();
        buffer.map_async(wgpu::MapMode::Read, 0..bytes.max(4), move |r| {
            let _ = tx.send(r);
        });
        PendingMap { rx }
    }

    /// Blocks until submission `index` has finished.
    pub fn wait(&self, index: SubmissionIndex) -> Result<(), String> {
        self.device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| format!("waiting for the GPU: {e}"))?;
        match self.take_error() {
            Some(e) => Err(e),
            None => Ok(()),
        }
    }

    /// Completes a mapping requested with [`Gpu::map_read`] (the work must have been waited
    /// for) and gives access to the bytes.
    pub fn mapped<'a>(
        &self,
        buffer: &'a Buffer,
        bytes: u64,
        pending: PendingMap,
    ) -> Result<Mapped<'a>, String> {
        let r = match pending.rx.try_recv() {
            Ok(r) => r,
            Err(_) => {
                self.device
                    .poll(wgpu::PollType::wait_indefinitely())
                    .map_err(|e| format!("waiting for the GPU: {e}"))?;
                pending
                    .rx
                    .recv()
                    .map_err(|_| String::from("buffer mapping was dropped"))?
            }
        };
        r.map_err(|e| format!("mapping a result buffer: {e}"))?;
        let view = buffer
            .slice(0..bytes.max(4))
            .get_mapped_range()
            .map_err(|e| format!("reading a mapped buffer: {e}"))?;
        Ok(Mapped {
            buffer,
            view: Some(view),
        })
    }

    /// Requests the mapping of `timer`'s results (call right after the timed submission).
    pub fn map_timer(&self, timer: &Timer) -> PendingMap {
        self.map_read(&timer.staging, 16)
    }

    /// Reads the two timestamps of `timer` (the work must have been waited for): the pass's
    /// device time in seconds.
    pub fn read_timer(&self, timer: &Timer, pending: PendingMap) -> Result<f64, String> {
        let m = self.mapped(&timer.staging, 16, pending)?;
        let b = m.bytes();
        let t0 = u64::from_le_bytes(b[0..8].try_into().map_err(|_| "timestamp bytes")?);
        let t1 = u64::from_le_bytes(b[8..16].try_into().map_err(|_| "timestamp bytes")?);
        Ok(t1.saturating_sub(t0) as f64 * timer.period_ns * 1e-9)
    }
}
