//! The tracer's buffer structures as Rust types: `#[repr(C)]`, plain old
//! data ([`bytemuck::Pod`]), one field per member of the WGSL structs of
//! `kernel/layout.wgsl`, under the same names. Each type's [`Layout`]
//! lists its fields' names, offsets and sizes, which a test compares with
//! what naga reflects from the WGSL module, so the two cannot drift apart.
//!
//! `vec3<f32>` members are `[f32; 3]` followed by a 4-byte member (WGSL
//! aligns a `vec3` to 16 bytes and packs the next scalar into its fourth
//! word), and every struct is a whole number of 16-byte rows.

/// A buffer structure's fields, for the layout test.
pub trait Layout {
    /// The WGSL struct's name.
    const NAME: &'static str;
    /// (name, byte offset, byte size) of each field, in order.
    const FIELDS: &'static [(&'static str, usize, usize)];
}

/// Declares a `#[repr(C)]` Pod struct and its [`Layout`].
macro_rules! gpu_struct {
    ($(#[$m:meta])* $name:ident { $($(#[$fm:meta])* $f:ident : $t:ty),* $(,)? }) => {
        $(#[$m])*
        #[repr(C)]
        #[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
        pub struct $name {
            $($(#[$fm])* pub $f: $t),*
        }
        impl Layout for $name {
            const NAME: &'static str = stringify!($name);
            const FIELDS: &'static [(&'static str, usize, usize)] = &[
                $((stringify!($f), std::mem::offset_of!($name, $f), std::mem::size_of::<$t>())),*
            ];
        }
    };
}

gpu_struct! {
    /// What a frame (one band of it) is rendered with: the image and band,
    /// the render settings, the camera, the environment's kind and the
    /// scene-wide flags (binding 1, a uniform buffer).
    Settings {
        /// Image width in pixels.
        width: u32,
        /// Image height in pixels.
        height: u32,
        /// The band's first column.
        x0: u32,
        /// The band's first row.
        y0: u32,
        /// The band's width.
        region_w: u32,
        /// The band's height.
        region_h: u32,
        /// Samples per pixel side.
        aa: u32,
        /// Sphere-tracing steps per ray at most.
        max_steps: u32,
        /// Hit threshold.
        hit_eps: f32,
        /// 1 when the threshold grows with distance.
        relative_eps: u32,
        /// Ray length at most.
        max_dist: f32,
        /// Step scale (under-relaxation).
        step_scale: f32,
        /// Normal method (0 central, 1 forward, 2 tetrahedron, 3 dual).
        normals: u32,
        /// The normal stencil's step.
        normal_h: f32,
        /// Its inverse.
        normal_inv_h: f32,
        /// Shadow mode (0 none … 4 Aaltonen).
        shadows: u32,
        /// Soft shadows' k.
        shadow_exponent: f32,
        /// Where shadow rays start.
        shadow_start: f32,
        /// Shadow rays' length at most.
        shadow_max_dist: f32,
        /// Shadow rays' steps at most.
        shadow_max_steps: u32,
        /// 1 with ambient occlusion.
        ao: u32,
        /// AO samples.
        ao_samples: u32,
        /// AO sample spacing.
        ao_step: f32,
        /// AO strength.
        ao_intensity: f32,
        /// The scene blend's width k.
        blend: f32,
        /// 0.25 / k (0 when k is 0).
        blend_quarter_over_k: f32,
        /// The material blend's width.
        material_blend_k: f32,
        /// The view (0 shaded, 1 steps, 2 normals, 3 uv, 4 mask, 5 gradient).
        view: u32,
        /// Path depth at most.
        max_depth: u32,
        /// Rays of less weight are dropped.
        min_weight: f32,
        /// Number of lights.
        n_lights: u32,
        /// Number of objects.
        n_objects: u32,
        /// Background colour.
        bg_r: f32,
        /// Background colour.
        bg_g: f32,
        /// Background colour.
        bg_b: f32,
        /// 1 when the AOVs are written.
        aovs: u32,
        /// Camera position.
        cam_x: f32,
        /// Camera position.
        cam_y: f32,
        /// Camera position.
        cam_z: f32,
        /// 1 for an equirectangular camera.
        projection: u32,
        /// Camera forward axis.
        fwd_x: f32,
        /// Camera forward axis.
        fwd_y: f32,
        /// Camera forward axis.
        fwd_z: f32,
        /// tan(fov / 2).
        tan_half: f32,
        /// Camera right axis.
        right_x: f32,
        /// Camera right axis.
        right_y: f32,
        /// Camera right axis.
        right_z: f32,
        /// Width / height.
        aspect: f32,
        /// Camera up axis.
        up_x: f32,
        /// Camera up axis.
        up_y: f32,
        /// Camera up axis.
        up_z: f32,
        /// Number of transparent objects.
        n_clear: u32,
        /// Environment kind (0 none, 1 equirect, 2 cube, 3 gradient).
        env_kind: u32,
        /// cos of the environment's rotation.
        env_cos: f32,
        /// sin of the environment's rotation.
        env_sin: f32,
        /// Environment intensity.
        env_k: f32,
        /// 1 when some object has a closed form.
        any_analytic: u32,
        /// What a sample's lane records (colour, or colour and AOVs).
        record: u32,
        /// Ray-stack entries per lane.
        stack_cap: u32,
        /// Interpreter registers per lane.
        reg_slots: u32,
        /// 1 when running out of steps is a miss.
        step_limit_miss: u32,
        /// Shadow floor.
        shadow_floor: f32,
        /// 1 when shadows darken the whole colour.
        shadow_all: u32,
        /// 1 for uniform AO weights.
        ao_uniform: u32,
        /// 1 when AO darkens the whole colour.
        ao_all: u32,
        /// Scene ambient light.
        amb_r: f32,
        /// Scene ambient light.
        amb_g: f32,
        /// Scene ambient light.
        amb_b: f32,
        /// 1 for fixed-step marching.
        fixed_march: u32,
        /// The fixed step.
        fixed_step: f32,
        /// Supersampling pattern (0 grid, 1 rotated, 2 jittered).
        aa_pattern: u32,
        /// Shadow rays' hit threshold.
        shadow_eps: f32,
        /// 1 when primary rays read the meshes' raster prepass.
        raster: u32,
        /// The prepass ids' row stride.
        raster_stride: u32,
        /// Parallax mode (0 none … 3 occlusion).
        parallax: u32,
        /// Parallax steps.
        parallax_steps: u32,
        /// The scene field's reach ([`isoray_render::reach::Reach`]): 0
        /// unknown (rays are not cut), 1 no surface in the domain, 2 the
        /// surface's box.
        reach_scene: u32,
        /// The same for the objects marched beside closed forms.
        reach_rest: u32,
        /// The same for the field shadow rays march where its distance
        /// is below the penumbra's (isoray-render's `Reaches::penumbra`).
        reach_penumbra: u32,
        /// Padding.
        pad5: u32,
        /// The reaches' domain: least corner (w unused).
        reach_domain_lo: [f32; 4],
        /// The reaches' domain: greatest corner.
        reach_domain_hi: [f32; 4],
        /// The scene field's surface box: least corner.
        reach_scene_lo: [f32; 4],
        /// The scene field's surface box: greatest corner.
        reach_scene_hi: [f32; 4],
        /// The rest's surface box: least corner.
        reach_rest_lo: [f32; 4],
        /// The rest's surface box: greatest corner.
        reach_rest_hi: [f32; 4],
        /// The penumbra's box: least corner.
        reach_penumbra_lo: [f32; 4],
        /// The penumbra's box: greatest corner.
        reach_penumbra_hi: [f32; 4],
    }
}

gpu_struct! {
    /// One light (binding 2).
    Light {
        /// 0 directional, 1 point, 2 sphere, 3 rectangle.
        kind: u32,
        /// Samples of an area light.
        samples: u32,
        /// Soft shadows' size.
        size: f32,
        /// Intensity.
        intensity: f32,
        /// Colour.
        cr: f32,
        /// Colour.
        cg: f32,
        /// Colour.
        cb: f32,
        /// Constant attenuation.
        att_c: f32,
        /// Linear attenuation.
        att_l: f32,
        /// Quadratic attenuation.
        att_q: f32,
        /// Position, or direction of a directional light.
        px: f32,
        /// Position, or direction.
        py: f32,
        /// Position, or direction.
        pz: f32,
        /// A sphere light's radius.
        radius: f32,
        /// A rectangle's first edge.
        ux: f32,
        /// A rectangle's first edge.
        uy: f32,
        /// A rectangle's first edge.
        uz: f32,
        /// A rectangle's second edge.
        vx: f32,
        /// A rectangle's second edge.
        vy: f32,
        /// A rectangle's second edge.
        vz: f32,
    }
}

gpu_struct! {
    /// One material, as isoray-shade rounds it to f32 (binding 3).
    Mat {
        /// Ambient colour.
        ambient: [f32; 3],
        /// Phong exponent.
        shininess: f32,
        /// Diffuse colour.
        diffuse: [f32; 3],
        /// Transparency.
        transparency: f32,
        /// Specular colour.
        specular: [f32; 3],
        /// Index of refraction.
        ior: f32,
        /// Emission.
        emission: [f32; 3],
        /// 0 Phong, 1 Blinn-Phong.
        model: u32,
        /// Reflectivity.
        reflectivity: [f32; 3],
        /// 0 pow, 1 Schlick's specular.
        specular_function: u32,
        /// Absorption (Beer–Lambert σ).
        absorption: [f32; 3],
        /// 0 off, 1 Schlick, 2 exact.
        fresnel: u32,
        /// The checker's other material, or `u32::MAX`.
        checker_other: u32,
        /// The checker's square size.
        checker_size: f32,
        /// 1 when the specular term is weighted by Fresnel.
        spec_fresnel: u32,
        /// Padding.
        pad1: u32,
    }
}

gpu_struct! {
    /// One object (binding 4): its material, closed form and program.
    Obj {
        /// Material index.
        material: u32,
        /// Closed form: 0 none, 1 plane, 2 sphere.
        analytic: u32,
        /// The interpreter's program: first word.
        code_start: u32,
        /// The interpreter's program: length.
        code_len: u32,
        /// The interpreter's program: the result's register.
        out_slot: u32,
        /// The object's header in the dent buffer, or `NO_DENT`.
        dent: u32,
        /// Padding.
        pad1: u32,
        /// Padding.
        pad2: u32,
        /// The closed form: a plane's normal and offset, a sphere's centre
        /// and squared radius.
        a: [f32; 4],
    }
}

/// The bytes of a slice of buffer structures, one zeroed element when it
/// is empty (a storage buffer may not be empty).
pub(crate) fn bytes_of_all<T: bytemuck::Pod + Default>(items: &[T]) -> Vec<u8> {
    if items.is_empty() {
        bytemuck::bytes_of(&T::default()).to_vec()
    } else {
        bytemuck::cast_slice(items).to_vec()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tracer's module for a small scene, as the renderer compiles it.
    fn module() -> naga::Module {
        let scene = isoray_scene::load_str(
            "[[object]]\nshape = \"sphere(p, 1.0)\"\n[[light]]\ndirection = [0.0, 1.0, 0.0]\n",
            "layout.toml",
            &[],
        )
        .unwrap();
        let code = crate::SceneCode::new(&scene, crate::Kernel::Compiled).unwrap();
        let source = format!("const USE_CELLS: bool = false;\n{}", code.source);
        naga::front::wgsl::parse_str(&source).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)))
    }

    /// (name, offset, size) of each member of the WGSL struct `name`, and its size.
    fn reflected(module: &naga::Module, name: &str) -> (Vec<(String, usize, usize)>, usize) {
        let mut layouter = naga::proc::Layouter::default();
        layouter.update(module.to_ctx()).unwrap();
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no struct {name} in the tracer"));
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("{name} is not a struct");
        };
        let fields = members
            .iter()
            .map(|m| {
                let size = layouter[m.ty].size as usize;
                (m.name.clone().unwrap_or_default(), m.offset as usize, size)
            })
            .collect();
        (fields, *span as usize)
    }

    /// (name, offset, size) of each field of the Rust type.
    fn fields<T: Layout>() -> Vec<(String, usize, usize)> {
        T::FIELDS.iter().map(|&(n, o, s)| (n.to_string(), o, s)).collect()
    }

    fn check<T: Layout>(module: &naga::Module) {
        let (wgsl, span) = reflected(module, T::NAME);
        let rust = fields::<T>();
        assert_eq!(rust, wgsl, "{}: the Rust fields against the WGSL members", T::NAME);
        assert_eq!(
            std::mem::size_of::<T>(),
            span,
            "{}: the Rust size against the WGSL size",
            T::NAME
        );
    }

    #[test]
    fn every_buffer_structure_has_the_layout_the_wgsl_declares() {
        let module = module();
        check::<Settings>(&module);
        check::<Light>(&module);
        check::<Mat>(&module);
        check::<Obj>(&module);
    }

    #[test]
    fn the_check_sees_a_member_out_of_place() {
        // Swapping two WGSL members is caught (the test can fail).
        let source = "struct Light { samples: u32, kind: u32, size: f32, intensity: f32,\n\
                      cr: f32, cg: f32, cb: f32, att_c: f32, att_l: f32, att_q: f32, px: f32, py: f32,\n\
                      pz: f32, radius: f32, ux: f32, uy: f32, uz: f32, vx: f32, vy: f32, vz: f32 }\n\
                      @group(0) @binding(0) var<storage, read> l: array<Light>;\n";
        let module = naga::front::wgsl::parse_str(source).unwrap();
        let (wgsl, _) = reflected(&module, "Light");
        assert_ne!(fields::<Light>(), wgsl);
        assert_eq!(wgsl[0], ("samples".to_string(), 0, 4));
    }
}
