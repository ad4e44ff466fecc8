//! The meshes' raster prepass of the GPU renderer: the scene's
//! `[[mesh]]` triangles drawn by the GPU's rasteriser, with a depth buffer,
//! into a target of one texel per primary sample (`raster.wgsl`).
//!
//! Each texel keeps the nearest triangle under its sample, which the
//! tracer's primary ray then intersects exactly (the same Möller–Trumbore
//! test as the tree walk, so the same t) to cap its march: the mesh is
//! composited with the SDF objects through the depth each sample sees,
//! and either hides the other. Secondary and shadow rays still walk the
//! meshes' trees. The prepass serves the primary rays only where they lie
//! on the supersampled grid the rasteriser samples (a perspective camera
//! with the grid sample pattern, or one sample a pixel at its centre);
//! everywhere else the tracer walks the trees for every ray.

use isoray_scene::{AaPattern, Projection, Scene};

use crate::{Gpu, GpuError};

/// The near plane of the prepass's camera (scene units): triangles
/// closer to the camera than this are clipped away.
const NEAR: f32 = 1e-4;

/// A texel of the ids: 0, or the mesh + 1 in the top 8 bits and the
/// triangle below, so at most 254 meshes of at most 2²⁴ triangles.
const MAX_MESHES: usize = 254;
const MAX_TRIANGLES: usize = 1 << 24;

/// The prepass's render target format: one id per texel.
const IDS: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The size, in samples, of the grid the primary rays of `scene` lie on,
/// when the prepass can serve them (see the module's documentation).
pub(crate) fn grid(scene: &Scene) -> Option<(u32, u32)> {
    let r = &scene.render;
    let on_grid = r.aa_pattern == AaPattern::Grid || (r.aa == 1 && r.aa_pattern == AaPattern::Rotated);
    let fits =
        scene.meshes.len() <= MAX_MESHES && scene.meshes.iter().all(|m| m.bvh().triangles().len() < MAX_TRIANGLES);
    (!scene.meshes.is_empty() && scene.camera.projection == Projection::Perspective && on_grid && fits)
        .then(|| (r.width * r.aa, r.height * r.aa))
}

/// The prepass's ids, copied into a storage buffer the tracer reads:
/// `stride` words a row.
pub(crate) struct RasterIds {
    pub buffer: wgpu::Buffer,
    pub stride: u32,
}

/// The prepass's pipeline.
pub(crate) struct MeshRaster {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
}

impl MeshRaster {
    pub(crate) fn new(gpu: &Gpu) -> Result<MeshRaster, GpuError> {
        let device = &gpu.device;
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("mesh raster"),
            source: wgpu::ShaderSource::Wgsl(include_str!("raster.wgsl").into()),
        });
        let entry = |binding, ty| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX,
            ty: wgpu::BindingType::Buffer {
                ty,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("mesh raster"),
            entries: &[
                entry(0, wgpu::BufferBindingType::Storage { read_only: true }),
                entry(1, wgpu::BufferBindingType::Uniform),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("mesh raster"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("mesh raster"),
            layout: Some(&pipeline_layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            // Both sides of every triangle, as the tree walk.
            primitive: wgpu::PrimitiveState {
                cull_mode: None,
                ..Default::default()
            },
            // Reversed depth: the nearest triangle has the greatest.
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs"),
                compilation_options: Default::default(),
                targets: &[Some(IDS.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Gpu(format!("the mesh raster pipeline: {e}")));
        }
        Ok(MeshRaster { pipeline, layout })
    }

    /// Records the prepass of `scene` (whose meshes `mesh_buf` holds, as
    /// `pack::meshes` lays them out) on a `size` grid into `enc`, and the
    /// copy of its ids into the returned buffer; None when the grid is
    /// larger than the device's textures or storage buffers allow (the
    /// tracer then walks the trees).
    pub(crate) fn encode(
        &self,
        gpu: &Gpu,
        enc: &mut wgpu::CommandEncoder,
        scene: &Scene,
        mesh_buf: &wgpu::Buffer,
        (w, h): (u32, u32),
        timestamp_writes: Option<wgpu::RenderPassTimestampWrites>,
    ) -> Option<RasterIds> {
        use wgpu::util::DeviceExt;
        let device = &gpu.device;
        let limits = device.limits();
        let stride = (w * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) / 4;
        let bytes = stride as u64 * h as u64 * 4;
        if w > limits.max_texture_dimension_2d
            || h > limits.max_texture_dimension_2d
            || bytes > limits.max_storage_buffer_binding_size
            || bytes > limits.max_buffer_size
        {
            return None;
        }
        let extent = wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        };
        let texture = |label, format, usage| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: extent,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let ids = texture(
            "mesh ids",
            IDS,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        );
        let depth = texture("mesh depth", DEPTH, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("mesh raster camera"),
            contents: &camera_words(scene)
                .iter()
                .flat_map(|x| x.to_le_bytes())
                .collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("mesh raster"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: mesh_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: camera.as_entire_binding(),
                },
            ],
        });
        let ids_view = ids.create_view(&Default::default());
        let depth_view = depth.create_view(&Default::default());
        {
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("mesh raster"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &ids_view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            for (k, m) in scene.meshes.iter().enumerate() {
                let corners = 3 * m.bvh().triangles().len() as u32;
                pass.draw(0..corners, k as u32..k as u32 + 1);
            }
        }
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("mesh ids"),
            size: bytes,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture: &ids,
                mip_level: 0,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(stride * 4),
                    rows_per_image: Some(h),
                },
            },
            extent,
        );
        Some(RasterIds { buffer, stride })
    }
}

/// The `Camera` uniform of `raster.wgsl`: the position (near in w), then
/// the rows taking p − position to clip space, so that a point on the ray
/// of image position (x, y) (in pixels, as the tracer's `camera_dir`)
/// lands on that position of the target.
fn camera_words(scene: &Scene) -> [f32; 16] {
    let c = &scene.camera;
    let [fwd, right, up] = c.basis();
    let tan = c.tan_half_fov();
    let aspect = scene.render.width as f64 / scene.render.height as f64;
    let row = |v: [f64; 3], s: f64| [(v[0] / s) as f32, (v[1] / s) as f32, (v[2] / s) as f32, 0.0];
    let p = c.position;
    let mut out = [0.0f32; 16];
    out[..4].copy_from_slice(&[p[0] as f32, p[1] as f32, p[2] as f32, NEAR]);
    out[4..8].copy_from_slice(&row(right, tan * aspect));
    out[8..12].copy_from_slice(&row(up, tan));
    out[12..].copy_from_slice(&row(fwd, 1.0));
    out
}
