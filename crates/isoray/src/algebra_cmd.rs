//! `isoray groebner` and `isoray implicitize`.

use std::io::Read;
use std::time::Duration;

use crate::jobs::{reporter, JobBar};

use isoray_algebra::coeff::is_prime;
use isoray_algebra::groebner::groebner_in;
use isoray_algebra::implicit::implicitize_groebner;
use isoray_algebra::{
    groebner, parse_poly, Algorithm, Budget, Criteria, Fp, GroebnerError, GroebnerOptions, ImplicitError,
    MonomialOrder, ParseError, Poly, Rat, Ring, Verify,
};

use crate::Failure;

fn bad(message: String) -> Failure {
    Failure { code: 2, message }
}

fn options(timeout: Option<f64>) -> Result<GroebnerOptions, Failure> {
    let time = match timeout {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 => Some(Duration::from_secs_f64(t)),
        Some(t) => {
            return Err(bad(format!(
                "--timeout must be a positive number of seconds, found {t}"
            )))
        }
    };
    Ok(GroebnerOptions {
        budget: Budget {
            time,
            interrupt: Some(crate::jobs::cancel_token()),
            ..Default::default()
        },
        ..Default::default()
    })
}

/// Renders a parse error located in `text`, which came from `origin`
/// (`argument 2`, or `FILE:LINE`).
fn located(origin: &str, text: &str, e: &ParseError) -> String {
    let caret_pad = " ".repeat(e.column - 1);
    let width = text[e.offset.min(text.len())..].chars().take(e.len).count().max(1);
    format!(
        "error: {}\n  --> {origin}:{}\n   |\n   | {text}\n   | {caret_pad}{}",
        e.message,
        e.column,
        "^".repeat(width)
    )
}

/// What `isoray groebner` was asked.
#[derive(clap::Args, Clone, Debug)]
pub struct GroebnerArgs {
    /// Variables, largest first: x,y,z.
    #[arg(long, value_delimiter = ',', required = true)]
    pub vars: Vec<String>,
    /// Monomial order: lex, deglex, grevlex, weighted:W1,W2,... or block:N1,N2,...
    #[arg(long, default_value = "grevlex")]
    pub order: String,
    /// 0 for the rationals, or a prime p for GF(p).
    #[arg(long, default_value_t = 0)]
    pub field: u64,
    /// Print statistics to stderr.
    #[arg(long)]
    pub stats: bool,
    /// Read polynomials from FILE, one per line (`-` for stdin).
    #[arg(long, value_name = "FILE")]
    pub input: Option<String>,
    /// Stop with an error after this many seconds.
    #[arg(long, value_name = "SECONDS")]
    pub timeout: Option<f64>,
    /// f4 (Faugère's F4; over Q multi-modular) or buchberger (the
    /// reference engine).
    #[arg(long, default_value = "f4")]
    pub algorithm: String,
    /// How F4's multi-modular basis over Q is checked: probabilistic
    /// (against a full run modulo a random prime) or exact (every S-pair
    /// and input reduces to zero over Q).
    #[arg(long, default_value = "probabilistic")]
    pub verify: String,
    /// Reduce every S-pair: neither the product (coprime leading
    /// monomials) nor the chain criterion discards any (the thesis's
    /// ablation; the basis is the same, the work grows).
    #[arg(long)]
    pub no_criteria: bool,
    /// Keep the product criterion but not the chain criterion
    /// (Gebauer–Möller's M, F and B_k).
    #[arg(long)]
    pub no_chain_criterion: bool,
    /// The generators (put `--` before them if one starts with `-`).
    pub polys: Vec<String>,
}

/// `isoray groebner`.
pub fn cmd_groebner(args: &GroebnerArgs) -> Result<(), Failure> {
    let (vars, order, field, stats) = (&args.vars, args.order.as_str(), args.field, args.stats);
    let (input, timeout, algorithm, polys) = (
        args.input.as_deref(),
        args.timeout,
        args.algorithm.as_str(),
        &args.polys,
    );
    let f4 = match algorithm {
        "f4" => true,
        "buchberger" => false,
        _ => {
            return Err(bad(format!(
                "--algorithm: expected f4 or buchberger, found `{algorithm}`"
            )))
        }
    };
    let verify = match args.verify.as_str() {
        "probabilistic" => Verify::Probabilistic,
        "exact" => Verify::Exact,
        v => return Err(bad(format!("--verify: expected probabilistic or exact, found `{v}`"))),
    };
    if vars.is_empty()
        || vars.iter().any(|v| {
            v.is_empty()
                || !v.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                || !v.starts_with(|c: char| c.is_ascii_alphabetic())
        })
    {
        return Err(bad(format!(
            "--vars must be a comma-separated list of variable names such as x,y,z, found `{}`",
            vars.join(",")
        )));
    }
    let Some(order) = MonomialOrder::parse(order) else {
        return Err(bad(format!(
            "--order: expected lex, deglex, grevlex, weighted:W1,W2,... or block:N1,N2,..., found `{order}`"
        )));
    };
    if let MonomialOrder::Weighted(w) = &order {
        if w.len() != vars.len() || w.contains(&0) {
            return Err(bad(format!(
                "--order weighted needs {} positive weights, one per variable",
                vars.len()
            )));
        }
    }
    if let MonomialOrder::Block(b) = &order {
        if b.iter().sum::<usize>() != vars.len() || b.contains(&0) {
            return Err(bad(format!(
                "--order block sizes must be positive and add up to {} (the number of variables)",
                vars.len()
            )));
        }
    }
    if field != 0 && (!is_prime(field) || field >= 1 << 63) {
        return Err(bad(format!(
            "--field must be 0 (the rationals) or a prime below 2^63, found {field}"
        )));
    }
    let ring = Ring::new(vars, order);
    // (text, origin) of every input polynomial.
    let mut texts: Vec<(String, String)> = polys
        .iter()
        .enumerate()
        .map(|(i, p)| (p.clone(), format!("argument {}", i + 1)))
        .collect();
    if let Some(path) = input {
        let (name, content) = if path == "-" {
            let mut s = String::new();
            std::io::stdin().read_to_string(&mut s).map_err(|e| Failure {
                code: 1,
                message: format!("cannot read stdin: {e}"),
            })?;
            ("stdin".to_string(), s)
        } else {
            let s = std::fs::read_to_string(path).map_err(|e| Failure {
                code: 1,
                message: format!("cannot read `{path}`: {e}"),
            })?;
            (path.to_string(), s)
        };
        for (n, line) in content.lines().enumerate() {
            let t = line.trim();
            if t.is_empty() || t.starts_with('#') {
                continue;
            }
            texts.push((line.to_string(), format!("{name}:{}", n + 1)));
        }
    }
    if texts.is_empty() {
        return Err(bad(
            "no polynomials given: pass them as arguments or with --input FILE".into()
        ));
    }
    let mut parsed: Vec<Poly<Rat>> = Vec::new();
    for (t, origin) in &texts {
        parsed.push(parse_poly(&ring, t).map_err(|e| bad(located(origin, t, &e)))?);
    }
    let bar = JobBar::for_terminal();
    let opts = GroebnerOptions {
        progress: reporter(&bar),
        algorithm: if f4 { Algorithm::F4 } else { Algorithm::Buchberger },
        verify,
        criteria: Criteria {
            product: !args.no_criteria,
            chain: !(args.no_criteria || args.no_chain_criterion),
        },
        ..options(timeout)?
    };
    let done = || {
        if let Some(b) = &bar {
            b.finish();
        }
    };
    let fail = |e: GroebnerError| match e {
        GroebnerError::Interrupted { .. } => crate::jobs::cancelled(),
        e => Failure {
            code: 1,
            message: e.to_string(),
        },
    };
    let (lines, st) = if field == 0 {
        let r = groebner(&ring, &parsed, &opts);
        done();
        let r = r.map_err(fail)?;
        (r.basis.iter().map(|p| p.display(&ring)).collect::<Vec<_>>(), r.stats)
    } else {
        let mut mods = Vec::new();
        for (p, (t, origin)) in parsed.iter().zip(&texts) {
            let mut terms = Vec::new();
            for (m, c) in p.terms() {
                let Some(v) = Fp::from_rat(c, field) else {
                    return Err(bad(format!(
                        "{origin}: the coefficient {c} of `{t}` has a denominator divisible by {field}"
                    )));
                };
                terms.push((m.clone(), v));
            }
            mods.push(Poly::from_terms(&ring, terms));
        }
        let r = if f4 && field < 1 << 31 {
            isoray_algebra::f4::f4_modp(&ring, &mods, &opts)
        } else {
            groebner_in(&ring, &mods, &opts)
        };
        done();
        let (basis, st) = r.map_err(fail)?;
        (basis.iter().map(|p| p.display(&ring)).collect(), st)
    };
    for l in lines {
        println!("{l}");
    }
    if stats {
        eprintln!("{st}");
    }
    Ok(())
}

/// `isoray implicitize`.
pub fn cmd_implicitize(
    x: &str,
    y: &str,
    z: Option<&str>,
    params: Option<&[String]>,
    method: &str,
    stats: bool,
    timeout: Option<f64>,
) -> Result<(), Failure> {
    if !matches!(method, "auto" | "groebner" | "interpolation" | "resultant") {
        return Err(bad(format!(
            "--method: expected auto, groebner, interpolation or resultant, found `{method}`"
        )));
    }
    let coords: Vec<&str> = match z {
        Some(z) => vec![x, y, z],
        None => vec![x, y],
    };
    let default_params: Vec<String> = if coords.len() == 3 {
        vec!["s".into(), "t".into()]
    } else {
        vec!["t".into()]
    };
    let params: Vec<&str> = params.unwrap_or(&default_params).iter().map(|s| s.as_str()).collect();
    let bar = JobBar::for_terminal();
    let opts = GroebnerOptions {
        progress: reporter(&bar),
        ..options(timeout)?
    };
    let interp = |time| {
        isoray_algebra::interp::implicitize_interpolation(
            &coords,
            &params,
            &isoray_algebra::interp::InterpolationOptions {
                time,
                interrupt: Some(crate::jobs::cancel_token()),
                progress: reporter(&bar),
                ..Default::default()
            },
        )
    };
    // The method auto chose and why, for --stats.
    let mut chosen: Option<String> = None;
    let result = match method {
        "groebner" => implicitize_groebner(&coords, &params, &opts),
        "interpolation" => interp(opts.budget.time),
        "resultant" => isoray_algebra::surface_resultant::implicitize_resultant(
            &coords,
            &params,
            &isoray_algebra::surface_resultant::ResultantOptions {
                time: opts.budget.time,
                interrupt: Some(crate::jobs::cancel_token()),
                progress: reporter(&bar),
            },
        ),
        _ => isoray_algebra::auto::implicitize_auto(
            &coords,
            &params,
            &isoray_algebra::auto::AutoOptions {
                time: opts.budget.time,
                interrupt: Some(crate::jobs::cancel_token()),
                progress: reporter(&bar),
            },
        )
        .map(|a| {
            chosen = Some(format!("method: {} ({})", a.method, a.estimate));
            a.implicit
        }),
    };
    if let Some(b) = &bar {
        b.finish();
    }
    match result {
        Ok(imp) => {
            println!("{}", imp.display());
            if stats {
                if let Some(c) = &chosen {
                    eprintln!("{c}");
                }
                eprintln!("{}", imp.stats);
            }
            Ok(())
        }
        Err(ImplicitError::Parse { coord, text, error }) => Err(bad(located(&format!("--{coord}"), &text, &error))),
        Err(ImplicitError::Cancelled | ImplicitError::Groebner(GroebnerError::Interrupted { .. })) => {
            Err(crate::jobs::cancelled())
        }
        Err(ImplicitError::Groebner(e)) => Err(Failure {
            code: 1,
            message: e.to_string(),
        }),
        Err(e @ (ImplicitError::TimeLimit { .. } | ImplicitError::BasePoints { .. } | ImplicitError::Resultant(_))) => {
            Err(Failure {
                code: 1,
                message: e.to_string(),
            })
        }
        Err(e) => Err(bad(e.to_string())),
    }
}
