//! A dentable object's maps: its uv mapping, its height map, and the
//! normal map kept up to date from it (only the changed rectangle, grown
//! by one texel, is recomputed), with the white height that makes the
//! normals those of the true dented surface.

use std::path::{Path, PathBuf};

use crate::field::{Field, March};
use crate::heightmap::{HeightMap, MapError};
use crate::imprint::{imprint_ortho, imprint_texel, Imprint, ImprintMethod, OrthoOptions, Sphere};
use crate::impulse::V3;
use crate::normalmap::{sobel_normal, NormalMap, NormalMapOptions, Wrap};
use crate::uv::UvMapping;

/// A dentable object's maps.
#[derive(Debug, Clone, PartialEq)]
pub struct DentMaps {
    /// How the object's surface lays out on the maps (its own coordinates).
    pub mapping: UvMapping,
    /// The heights.
    pub height: HeightMap,
    /// The normals (RGB) and heights (A) as the thesis packs them.
    pub normals: NormalMap,
    /// How the normals are computed from the heights.
    pub options: NormalMapOptions,
}

impl DentMaps {
    /// Untouched `size` × `size` maps whose heights span `range` scene
    /// units and whose texels are `texel` scene units wide: the white
    /// height is then range / texel texels, so the normals are the dented
    /// surface's own. Planar maps clamp at their borders; spherical ones
    /// wrap their columns.
    pub fn new(mapping: UvMapping, size: u32, range: f64, texel: f64) -> DentMaps {
        let options = NormalMapOptions {
            white_height: (range / texel) as f32,
            wrap: if mapping.wraps_columns() {
                Wrap::Columns
            } else {
                Wrap::Clamp
            },
            ..Default::default()
        };
        let height = HeightMap::new(size, size, range);
        let normals = NormalMap::of(height.texels(), size, size, &options);
        DentMaps {
            mapping,
            height,
            normals,
            options,
        }
    }

    /// Imprints impactor `b` (at its pushed pose, within `reach`) into
    /// the struck body `a`'s height map by `method`, all in `a`'s own
    /// coordinates; the ortho methods' camera sits on `contact` looking
    /// along −`n_c` (from `a` towards `b`) with pixels of side `pixel`.
    /// The normals are not updated ([`DentMaps::update_normals`]).
    #[allow(clippy::too_many_arguments)]
    pub fn imprint(
        &mut self,
        method: ImprintMethod,
        a: &dyn Field,
        b: &dyn Field,
        contact: V3,
        n_c: V3,
        reach: Sphere,
        pixel: f64,
    ) -> Imprint {
        let m = March::default();
        match method {
            ImprintMethod::Texel => imprint_texel(&mut self.height, &self.mapping, a, b, reach, m),
            ImprintMethod::Ortho | ImprintMethod::OrthoProjected => {
                let opts = OrthoOptions {
                    project_on_normal: method == ImprintMethod::OrthoProjected,
                };
                imprint_ortho(
                    &mut self.height,
                    &self.mapping,
                    a,
                    b,
                    contact,
                    n_c,
                    reach,
                    pixel,
                    opts,
                    m,
                )
            }
        }
    }

    /// Recomputes the normals the heights changed since the last call;
    /// returns the texels recomputed.
    pub fn update_normals(&mut self) -> u64 {
        match self.height.take_dirty() {
            Some(r) => self.normals.update(self.height.texels(), &self.options, r),
            None => 0,
        }
    }

    /// The tangent-space normal (x along +u, y towards row 0, z out of the
    /// surface) at (u, v), bilinear between texel centres, unit length: the
    /// normal map's normals in full precision (from the heights, as the
    /// 8-bit map is made, without its rounding).
    pub fn normal_at(&self, uv: [f64; 2]) -> V3 {
        let mut n = [0.0f64; 3];
        for (x, y, wgt) in self.corners(uv) {
            let (v, _) = sobel_normal(
                self.height.texels(),
                self.height.width(),
                self.height.height(),
                x,
                y,
                &self.options,
            );
            for i in 0..3 {
                n[i] += wgt * v[i];
            }
        }
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        [n[0] / l, n[1] / l, n[2] / l]
    }

    /// How deep the dents are at uv (scene units below the untouched
    /// surface, ≥ 0), bilinear over the texels as [`DentMaps::normal_at`].
    pub fn depth_at(&self, uv: [f64; 2]) -> f64 {
        self.corners(uv)
            .into_iter()
            .map(|(x, y, wgt)| wgt * (-self.height.displacement(x, y)).max(0.0))
            .sum()
    }

    /// The four texels around uv (pixel centres at half-integers) and
    /// their bilinear weights: columns wrap unless the map clamps, rows
    /// clamp.
    fn corners(&self, uv: [f64; 2]) -> [(u32, u32, f64); 4] {
        let (w, h) = (self.height.width() as i64, self.height.height() as i64);
        let fx = uv[0] * w as f64 - 0.5;
        let fy = uv[1] * h as f64 - 0.5;
        let (x0, y0) = (fx.floor() as i64, fy.floor() as i64);
        let (tx, ty) = (fx - x0 as f64, fy - y0 as f64);
        let col = |x: i64| {
            if self.options.wrap == Wrap::Clamp {
                x.clamp(0, w - 1) as u32
            } else {
                x.rem_euclid(w) as u32
            }
        };
        let row = |y: i64| y.clamp(0, h - 1) as u32;
        [
            (col(x0), row(y0), (1.0 - tx) * (1.0 - ty)),
            (col(x0 + 1), row(y0), tx * (1.0 - ty)),
            (col(x0), row(y0 + 1), (1.0 - tx) * ty),
            (col(x0 + 1), row(y0 + 1), tx * ty),
        ]
    }

    /// The files of object `name`'s maps in `dir`: `NAME-height.png`
    /// (16-bit grey) and `NAME-normal.png` (8-bit RGBA).
    pub fn paths(dir: &Path, name: &str) -> (PathBuf, PathBuf) {
        (
            dir.join(format!("{name}-height.png")),
            dir.join(format!("{name}-normal.png")),
        )
    }

    /// Writes both maps into `dir`, atomically each.
    pub fn write(&self, dir: &Path, name: &str) -> Result<(), MapError> {
        let (h, n) = DentMaps::paths(dir, name);
        self.height.write_png16(&h)?;
        self.normals.write_png(&n)
    }

    /// These maps with the heights of `NAME-height.png` in `dir` (the
    /// normals recomputed from them); an error names the file when its
    /// size differs from these maps'.
    pub fn with_heights_from(&self, dir: &Path, name: &str) -> Result<DentMaps, MapError> {
        let (path, _) = DentMaps::paths(dir, name);
        let height = HeightMap::read_png(&path, self.height.range)?;
        if (height.width(), height.height()) != (self.height.width(), self.height.height()) {
            return Err(MapError::Io {
                path: path.display().to_string(),
                message: format!(
                    "a {}x{} map, but the object's dent_map.size makes {}x{}",
                    height.width(),
                    height.height(),
                    self.height.width(),
                    self.height.height()
                ),
            });
        }
        let normals = NormalMap::of(height.texels(), height.width(), height.height(), &self.options);
        Ok(DentMaps {
            mapping: self.mapping.clone(),
            height,
            normals,
            options: self.options,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_untouched_map_is_flat_and_a_dent_tilts_its_rim_inwards() {
        let mapping = UvMapping::named("planar-xz", [-1.0; 3], [1.0; 3]).unwrap();
        let mut m = DentMaps::new(mapping, 64, 0.1, 2.0 / 64.0);
        let n = m.normal_at([0.3, 0.7]);
        assert!((n[2] - 1.0).abs() < 1e-3, "{n:?}");
        // A 45° slope: one texel (2/64) down per texel across, on the left
        // half of a ramp rising to +u... heights falling towards +u tilt +x.
        for y in 0..64 {
            for x in 0..64 {
                let depth = (x as f64) * 2.0 / 64.0 * 0.1; // 0.1 scene units per scene unit
                m.height.lower_min(x, y, m.height.value_of(-depth.min(0.04)));
            }
        }
        assert!(m.update_normals() > 0);
        let n = m.normal_at([0.1, 0.5]);
        // Slope 0.1: the normal (0.1, 0, 1)/|…| tilted towards +u.
        assert!(
            (n[0] - 0.1 / (1.01f64).sqrt()).abs() < 0.01 && n[1].abs() < 0.01,
            "{n:?}"
        );
    }

    #[test]
    fn maps_write_and_read_back() {
        let d = std::env::temp_dir().join(format!("isoray-dent-maps-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let mapping = UvMapping::named("spherical", [-1.0; 3], [1.0; 3]).unwrap();
        let mut m = DentMaps::new(mapping, 32, 0.1, 0.1);
        m.height.lower_min(5, 6, 0.25);
        m.update_normals();
        m.write(&d, "ball").unwrap();
        let back = DentMaps::new(m.mapping.clone(), 32, 0.1, 0.1)
            .with_heights_from(&d, "ball")
            .unwrap();
        assert!((back.height.get(5, 6) - 0.25).abs() < 1e-4);
        assert_eq!(back.normals, m.normals);
        let wrong = DentMaps::new(m.mapping.clone(), 16, 0.1, 0.1)
            .with_heights_from(&d, "ball")
            .unwrap_err();
        assert!(wrong.to_string().contains("32x32"), "{wrong}");
    }
}
