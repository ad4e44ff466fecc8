//! Reading one table's keys, checked, with errors at their place.

use isoray_shape::diag::suggest;

use crate::doc::{Entry, Item, Located};
use crate::error::{SceneError, Sources};
use crate::model::Vec3;
use crate::schema::{KeySpec, Kind};

type Result<T> = std::result::Result<T, SceneError>;

/// Reads the keys of one table, remembering which were used.
pub(crate) struct Reader<'a> {
    pub(crate) src: &'a Sources,
    entries: &'a [Entry],
    ctx: String,
    used: Vec<bool>,
}

impl<'a> Reader<'a> {
    pub(crate) fn new(src: &'a Sources, v: &'a Located, ctx: &str) -> Result<Reader<'a>> {
        match &v.item {
            Item::Table(entries) => Ok(Reader {
                src,
                entries,
                ctx: ctx.to_string(),
                used: vec![false; entries.len()],
            }),
            other => Err(src.error(
                v.origin,
                format!("`{ctx}` must be a table, found {}", other.type_name()),
                Some("expected a table"),
                &[],
            )),
        }
    }

    pub(crate) fn get(&mut self, key: &str) -> Option<&'a Located> {
        let i = self.entries.iter().rposition(|e| e.key == key)?;
        self.used[i] = true;
        Some(&self.entries[i].value)
    }

    pub(crate) fn err(&self, v: &Located, key: &str, expected: &str) -> SceneError {
        self.src
            .error(
                v.origin,
                format!("`{}.{key}`: expected {expected}, found {}", self.ctx, describe(&v.item)),
                Some(&format!("expected {expected}")),
                &[],
            )
            .with_key(format!("{}.{key}", self.ctx))
    }

    pub(crate) fn num_in(&mut self, key: &str, default: f64, ok: impl Fn(f64) -> bool, expected: &str) -> Result<f64> {
        let Some(v) = self.get(key) else {
            return Ok(default);
        };
        match v.item {
            Item::Num(x, _) if ok(x) => Ok(x),
            _ => Err(self.err(v, key, expected)),
        }
    }

    pub(crate) fn int(&mut self, key: &str, default: u32, lo: u32, hi: u32) -> Result<u32> {
        let Some(v) = self.get(key) else {
            return Ok(default);
        };
        match v.item {
            Item::Num(x, _) if x.fract() == 0.0 && x >= lo as f64 && x <= hi as f64 => Ok(x as u32),
            _ => Err(self.err(v, key, &format!("an integer from {lo} to {hi}"))),
        }
    }

    /// A boolean that is read but not marked as used when absent.
    pub(crate) fn peek_bool(&mut self, key: &str) -> Result<bool> {
        self.boolean(key, false)
    }

    pub(crate) fn boolean(&mut self, key: &str, default: bool) -> Result<bool> {
        let Some(v) = self.get(key) else {
            return Ok(default);
        };
        match v.item {
            Item::Bool(b) => Ok(b),
            _ => Err(self.err(v, key, "`true` or `false`")),
        }
    }

    pub(crate) fn vec3_opt(&mut self, key: &str) -> Result<Option<Vec3>> {
        let Some(v) = self.get(key) else {
            return Ok(None);
        };
        if let Item::Array(items) = &v.item {
            if items.len() == 3 {
                let mut out = [0.0; 3];
                for (o, it) in out.iter_mut().zip(items) {
                    match it.item {
                        Item::Num(x, _) if x.is_finite() => *o = x,
                        _ => return Err(self.err(it, key, "a number in the 3-component array")),
                    }
                }
                return Ok(Some(out));
            }
        }
        Err(self.err(v, key, "an array of 3 numbers, like [1.0, 0.5, 0.0]"))
    }

    pub(crate) fn vec3(&mut self, key: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.vec3_opt(key)?.unwrap_or(default))
    }

    /// A number or colour with every component in [0, 1] (a number is grey).
    pub(crate) fn unit_color(&mut self, key: &str, default: Vec3) -> Result<Vec3> {
        let Some(v) = self.get(key) else {
            return Ok(default);
        };
        let ok = |x: f64| x.is_finite() && (0.0..=1.0).contains(&x);
        match &v.item {
            Item::Num(x, _) if ok(*x) => Ok([*x; 3]),
            Item::Array(items) if items.len() == 3 => {
                let mut out = [0.0; 3];
                for (o, it) in out.iter_mut().zip(items) {
                    match it.item {
                        Item::Num(x, _) if ok(x) => *o = x,
                        _ => return Err(self.err(it, key, "a number from 0 to 1 in the colour")),
                    }
                }
                Ok(out)
            }
            _ => Err(self.err(v, key, "a number from 0 to 1, or a colour [r, g, b] of such numbers")),
        }
    }

    pub(crate) fn color(&mut self, key: &str, default: Vec3) -> Result<Vec3> {
        let c = self.vec3(key, default)?;
        if c.iter().any(|x| *x < 0.0) {
            let v = self.get(key).expect("just read");
            return Err(self.err(v, key, "a colour with components ≥ 0"));
        }
        Ok(c)
    }

    pub(crate) fn string(&mut self, key: &str) -> Result<Option<(&'a str, &'a Located)>> {
        let Some(v) = self.get(key) else {
            return Ok(None);
        };
        match &v.item {
            Item::Str(s, _) => Ok(Some((s.as_str(), v))),
            _ => Err(self.err(v, key, "a string")),
        }
    }

    pub(crate) fn choice<T: Copy>(&mut self, key: &str, options: &[(&str, T)], default: T) -> Result<T> {
        let Some((s, v)) = self.string(key)? else {
            return Ok(default);
        };
        if let Some((_, t)) = options.iter().find(|(n, _)| *n == s) {
            return Ok(*t);
        }
        let names: Vec<String> = options.iter().map(|(n, _)| format!("\"{n}\"")).collect();
        let mut notes = Vec::new();
        if let Some(sg) = suggest(s, options.iter().map(|(n, _)| *n)) {
            notes.push(format!("did you mean \"{sg}\"?"));
        }
        Err(self
            .src
            .error(
                v.origin,
                format!(
                    "`{}.{key}`: expected one of {}, found \"{s}\"",
                    self.ctx,
                    names.join(", ")
                ),
                Some("unknown choice"),
                &notes,
            )
            .with_key(format!("{}.{key}", self.ctx)))
    }

    /// A number key read by its description (default and range).
    pub(crate) fn num_key(&mut self, spec: &KeySpec) -> Result<f64> {
        let Kind::Num(range) = spec.kind else {
            unreachable!("`{}` is a number key", spec.name)
        };
        self.num_in(spec.name, spec.default_f64(), |x| range.contains(x), range.expected)
    }

    /// A boolean key read by its description.
    pub(crate) fn bool_key(&mut self, spec: &KeySpec) -> Result<bool> {
        self.boolean(spec.name, spec.default == "true")
    }

    /// A choice key read by its description: the name chosen.
    pub(crate) fn choice_key(&mut self, spec: &KeySpec) -> Result<&'static str> {
        let Kind::Choice(names) = &spec.kind else {
            unreachable!("`{}` is a choice key", spec.name)
        };
        let options: Vec<(&str, &'static str)> = names.iter().map(|n| (*n, *n)).collect();
        let default = names
            .iter()
            .copied()
            .find(|n| spec.default.trim_matches('"') == *n)
            .unwrap_or(names[0]);
        self.choice(spec.name, &options, default)
    }

    /// Errors on keys that were never read.
    /// Errors on keys of a described table that were never read.
    pub(crate) fn finish_keys(self, keys: &[KeySpec]) -> Result<()> {
        self.finish(&crate::schema::names(keys))
    }

    /// Errors on keys that were never read (`known`: the table's keys).
    pub(crate) fn finish(self, known: &[&str]) -> Result<()> {
        for (e, used) in self.entries.iter().zip(&self.used) {
            if !used && known.contains(&e.key.as_str()) {
                return Err(self
                    .src
                    .error(
                        e.key_origin,
                        format!("`{}.{}` does not apply here", self.ctx, e.key),
                        Some("not used with these settings"),
                        &[match e.key.as_str() {
                            "direction" => {
                                "`direction` is for directional lights; point lights have a `position`".to_string()
                            }
                            "position" => {
                                "`position` is for point lights; directional lights have a `direction`".to_string()
                            }
                            _ => "remove it, or change the setting that makes it unused".to_string(),
                        }],
                    )
                    .with_key(format!("{}.{}", self.ctx, e.key)));
            }
            if !used {
                let mut notes = vec![format!("known keys: {}", known.join(", "))];
                if let Some(s) = suggest(&e.key, known.iter().copied()) {
                    notes.insert(0, format!("did you mean `{s}`?"));
                }
                return Err(self
                    .src
                    .error(
                        e.key_origin,
                        format!("unknown key `{}` in `{}`", e.key, self.ctx),
                        Some("unknown key"),
                        &notes,
                    )
                    .with_key(format!("{}.{}", self.ctx, e.key)));
            }
        }
        Ok(())
    }
}

pub(crate) fn describe(item: &Item) -> String {
    match item {
        Item::Str(s, _) => format!("the string \"{}\"", truncate(s)),
        Item::Num(x, _) => format!("{x}"),
        Item::Bool(b) => format!("`{b}`"),
        other => other.type_name().to_string(),
    }
}

fn truncate(s: &str) -> String {
    if s.chars().count() > 40 {
        format!("{}…", s.chars().take(40).collect::<String>())
    } else {
        s.to_string()
    }
}
