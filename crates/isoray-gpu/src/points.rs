//! Evaluating a shape tape at points in a compute pass: a tape's compiled
//! WGSL function, or its program run by the interpreter.

use isoray_shape::wgsl::interval::INTERVAL_PRELUDE;
use isoray_shape::wgsl::{interpreter, Program, WgslFunction, PRELUDE};
use wgpu::util::DeviceExt;

use crate::{Gpu, GpuError};

/// A compute pipeline that evaluates a tape at points: one tape's WGSL
/// function ([`Gpu::point_shader`]), or the interpreter, which runs any
/// program given at evaluation ([`Gpu::program_shader`]).
#[derive(Debug)]
pub struct PointShader {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

const WORKGROUP: u32 = 64;

/// The compute shader whose lane i runs `lane` (which reads the lane's
/// part of `points` and writes its part of `out`, `outputs` words), after
/// `code` (functions reading `iso_in` and, for the interpreter, `iso_code`).
fn module(code: &str, outputs: u32, lane: &str) -> String {
    format!(
        "{PRELUDE}\n{INTERVAL_PRELUDE}\n@group(0) @binding(0) var<storage, read> iso_in: array<f32>;\n\
         @group(0) @binding(1) var<storage, read> points: array<f32>;\n\
         @group(0) @binding(2) var<storage, read_write> out: array<f32>;\n\
         @group(0) @binding(3) var<storage, read> iso_code: array<u32>;\n\
         @group(0) @binding(4) var<storage, read_write> iso_regs: array<vec4<f32>>;\n\
         var<private> iso_reg_base: u32;\n\
         {code}\n\
         @compute @workgroup_size({WORKGROUP})\n\
         fn main(@builtin(global_invocation_id) id: vec3<u32>) {{\n\
         \x20   let i = id.x;\n\
         \x20   if ({outputs}u * i >= arrayLength(&out)) {{ return; }}\n\
         \x20   iso_reg_base = i * iso_code[2];\n\
         {lane}\
         }}\n"
    )
}

/// The lane of a point shader: `out[i] = {call}` at the point `p`.
fn point_lane(call: &str) -> String {
    format!("    let p = vec3<f32>(points[3u * i], points[3u * i + 1u], points[3u * i + 2u]);\n    out[i] = {call};\n")
}

/// The compute shader around `function` (named `name`, reading `iso_in`).
pub fn point_module(function: &WgslFunction, name: &str) -> String {
    module(&function.code, 1, &point_lane(&format!("{name}(p)")))
}

/// The compute shader around the interval `function` (named `name`, as
/// [`isoray_shape::wgsl::interval::emit_tape_interval`] writes it): lane i
/// reads box i (its low corner, then its high corner) and writes its
/// bounds' low and high ends.
pub fn interval_module(function: &WgslFunction, name: &str) -> String {
    module(
        &function.code,
        2,
        &format!(
            "    let lo = vec3<f32>(points[6u * i], points[6u * i + 1u], points[6u * i + 2u]);\n    \
             let hi = vec3<f32>(points[6u * i + 3u], points[6u * i + 4u], points[6u * i + 5u]);\n    \
             let r = {name}(lo, hi);\n    out[2u * i] = r.x;\n    out[2u * i + 1u] = r.y;\n"
        ),
    )
}

/// Words of the program buffer before the program: its length, result
/// slot and register count.
const PROGRAM_HEADER: u32 = 4;

/// The interpreter's compute shader: the program buffer holds the
/// instruction count, the result slot and the register count, then the
/// instructions; each point's registers are its part of binding 4.
pub fn program_module() -> String {
    module(
        &interpreter("iso_code", "iso_in"),
        1,
        &point_lane(&format!("iso_run({PROGRAM_HEADER}u, iso_code[0], iso_code[1], p)")),
    )
}

/// What the lanes of a point or interval shader read and write: lane i
/// reads its `words` of `flat` (3 of a point, 6 of a box) and writes
/// `outputs` words.
struct Lanes<'a> {
    flat: &'a [f32],
    words: usize,
    outputs: usize,
}

impl Gpu {
    /// Compiles the compute pipeline evaluating `function`, whose name in
    /// its code is `name` and whose input-derived values it reads from
    /// `iso_in` from index 0 (as [`isoray_shape::wgsl::emit_tape`] writes
    /// it with `buffer = "iso_in"`, `base = 0`).
    pub fn point_shader(&self, function: &WgslFunction, name: &str) -> Result<PointShader, GpuError> {
        self.points_pipeline(&point_module(function, name), &format!("`{name}`"))
    }

    /// Compiles the compute pipeline bounding `function` over boxes
    /// ([`Gpu::eval_boxes`]), an interval function named `name` reading
    /// `iso_in` from index 0 (as
    /// [`isoray_shape::wgsl::interval::emit_tape_interval`] writes it with
    /// `buffer = "iso_in"`, `base = 0`).
    pub fn interval_shader(&self, function: &WgslFunction, name: &str) -> Result<PointShader, GpuError> {
        self.points_pipeline(&interval_module(function, name), &format!("`{name}`"))
    }

    /// Compiles the interpreter's point pipeline, which evaluates any
    /// program ([`Gpu::eval_program`]): one pipeline for every tape.
    pub fn program_shader(&self) -> Result<PointShader, GpuError> {
        self.points_pipeline(&program_module(), "the interpreter")
    }

    fn points_pipeline(&self, source: &str, what: &str) -> Result<PointShader, GpuError> {
        let storage = |read_only| wgpu::BufferBindingType::Storage { read_only };
        let (pipeline, layout) = self.compute_pipeline(
            source,
            what,
            &[
                storage(true),
                storage(true),
                storage(false),
                storage(true),
                storage(false),
            ],
        )?;
        Ok(PointShader { pipeline, layout })
    }

    /// The values of the shader's tape at `points`, with `inputs` in its
    /// input buffer (see [`WgslFunction::fill`]).
    pub fn eval_points(&self, shader: &PointShader, inputs: &[f32], points: &[[f32; 3]]) -> Result<Vec<f32>, GpuError> {
        let flat: Vec<f32> = points.iter().flatten().copied().collect();
        self.run_points(
            shader,
            inputs,
            &[0; PROGRAM_HEADER as usize],
            0,
            Lanes {
                flat: &flat,
                words: 3,
                outputs: 1,
            },
        )
    }

    /// The bounds (low and high ends) of the interval shader's tape over
    /// `boxes` (each its low corner, then its high corner; see
    /// [`isoray_shape::wgsl::interval::box_ends`] for f64 boxes), with
    /// `inputs` in its input buffer.
    pub fn eval_boxes(
        &self,
        shader: &PointShader,
        inputs: &[f32],
        boxes: &[[[f32; 3]; 2]],
    ) -> Result<Vec<[f32; 2]>, GpuError> {
        let flat: Vec<f32> = boxes.iter().flatten().flatten().copied().collect();
        let ends = self.run_points(
            shader,
            inputs,
            &[0; PROGRAM_HEADER as usize],
            0,
            Lanes {
                flat: &flat,
                words: 6,
                outputs: 2,
            },
        )?;
        Ok(ends.chunks_exact(2).map(|e| [e[0], e[1]]).collect())
    }

    /// The values of `program` at `points`, run by the interpreter's
    /// pipeline ([`Gpu::program_shader`]), with `inputs` in its input
    /// buffer (see [`Program::fill`]).
    pub fn eval_program(
        &self,
        shader: &PointShader,
        program: &Program,
        inputs: &[f32],
        points: &[[f32; 3]],
    ) -> Result<Vec<f32>, GpuError> {
        let mut code = vec![program.len() as u32, program.output, program.slots as u32, 0];
        code.extend(&program.code);
        let flat: Vec<f32> = points.iter().flatten().copied().collect();
        self.run_points(
            shader,
            inputs,
            &code,
            program.slots,
            Lanes {
                flat: &flat,
                words: 3,
                outputs: 1,
            },
        )
    }

    /// Runs the shader's lanes over `lanes`.
    fn run_points(
        &self,
        shader: &PointShader,
        inputs: &[f32],
        code: &[u32],
        registers: usize,
        Lanes { flat, words, outputs }: Lanes<'_>,
    ) -> Result<Vec<f32>, GpuError> {
        let lanes = flat.len() / words;
        if lanes == 0 {
            return Ok(Vec::new());
        }
        let bytes = |v: &[f32]| -> Vec<u8> { v.iter().flat_map(|x| x.to_le_bytes()).collect() };
        let mut input_values = inputs.to_vec();
        if input_values.is_empty() {
            input_values.push(0.0); // a storage buffer may not be empty
        }
        let storage = wgpu::BufferUsages::STORAGE;
        let in_buf = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("iso_in"),
            contents: &bytes(&input_values),
            usage: storage,
        });
        let pt_buf = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("points"),
            contents: &bytes(flat),
            usage: storage,
        });
        let code_buf = self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("iso_code"),
            contents: &crate::pack::Words::bytes_of(code),
            usage: storage,
        });
        let regs_buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("iso_regs"),
            size: (lanes * registers).max(1) as u64 * 16,
            usage: storage,
            mapped_at_creation: false,
        });
        let size = (lanes * outputs * 4) as u64;
        let out_buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("out"),
            size,
            usage: storage | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let read_buf = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("read-back"),
            size,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        let bind = self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("points"),
            layout: &shader.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: in_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: pt_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: out_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: code_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: regs_buf.as_entire_binding(),
                },
            ],
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_pipeline(&shader.pipeline);
            pass.set_bind_group(0, &bind, &[]);
            pass.dispatch_workgroups((lanes as u32).div_ceil(WORKGROUP), 1, 1);
        }
        enc.copy_buffer_to_buffer(&out_buf, 0, &read_buf, 0, size);
        let submission = self.queue.submit([enc.finish()]);
        Ok(self
            .read_back(&read_buf, submission)?
            .into_iter()
            .map(f32::from_bits)
            .collect())
    }
}
