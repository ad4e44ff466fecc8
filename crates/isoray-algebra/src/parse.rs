//! Parsing polynomials and rational expressions: `x^2*y - 3/2*z + 1`,
//! `(s^2+t^2+1)^3`, `2*s/(s^2+t^2+1)`. Juxtaposition multiplies (`2s`, `st`
//! when `s` and `t` are variables), as in written mathematics.

use num_traits::{One, Signed};

use crate::coeff::{Int, Rat};
use crate::monomial::Monomial;
use crate::poly::{Poly, Ring};

/// A syntax or name error with its byte position in the input.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message} (at column {})", column)]
pub struct ParseError {
    /// What went wrong and what was expected.
    pub message: String,
    /// Byte offset of the offending text.
    pub offset: usize,
    /// Its length in bytes (at least 1).
    pub len: usize,
    /// 1-based column (in characters).
    pub column: usize,
}

impl ParseError {
    fn new(text: &str, offset: usize, len: usize, message: impl Into<String>) -> Self {
        let offset = offset.min(text.len());
        ParseError {
            message: message.into(),
            offset,
            len: len.max(1),
            column: text[..offset].chars().count() + 1,
        }
    }

    /// The input with a caret line under the error, for terminals.
    pub fn render(&self, text: &str) -> String {
        let line = text.replace('\n', " ");
        format!(
            "error: {}\n  | {line}\n  | {}{}",
            self.message,
            " ".repeat(self.column - 1),
            "^".repeat(self.len.min(line.len().saturating_sub(self.column - 1)).max(1))
        )
    }
}

/// A quotient of polynomials over Q (not reduced to lowest terms).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RatFunc {
    /// Numerator.
    pub num: Poly<Rat>,
    /// Denominator (never zero).
    pub den: Poly<Rat>,
}

#[derive(Debug, Clone, PartialEq)]
enum Tok {
    Num(Rat),
    Ident(String),
    Op(char),
    End,
}

fn lex(text: &str) -> Result<Vec<(Tok, usize, usize)>, ParseError> {
    let b = text.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        let start = i;
        if c.is_ascii_digit() || c == b'.' {
            while i < b.len() && b[i].is_ascii_digit() {
                i += 1;
            }
            let int_part = &text[start..i];
            let mut frac_part = "";
            if i < b.len() && b[i] == b'.' {
                i += 1;
                let fs = i;
                while i < b.len() && b[i].is_ascii_digit() {
                    i += 1;
                }
                frac_part = &text[fs..i];
            }
            if int_part.is_empty() && frac_part.is_empty() {
                return Err(ParseError::new(text, start, 1, "expected a number"));
            }
            // Exact decimal: 1.25 = 125/100.
            let digits = format!("{int_part}{frac_part}");
            let n: Int = digits
                .parse()
                .map_err(|_| ParseError::new(text, start, i - start, "malformed number"))?;
            let d = num_traits::pow(Int::from(10), frac_part.len());
            out.push((Tok::Num(Rat::new(n, d)), start, i - start));
            continue;
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            out.push((Tok::Ident(text[start..i].to_string()), start, i - start));
            continue;
        }
        if c == b'*' && b.get(i + 1) == Some(&b'*') {
            out.push((Tok::Op('^'), start, 2));
            i += 2;
            continue;
        }
        if b"+-*/^()".contains(&c) {
            out.push((Tok::Op(c as char), start, 1));
            i += 1;
            continue;
        }
        let ch = text[i..].chars().next().unwrap_or('?');
        return Err(ParseError::new(
            text,
            i,
            ch.len_utf8(),
            format!("unexpected character `{ch}`"),
        ));
    }
    out.push((Tok::End, text.len(), 1));
    Ok(out)
}

struct Parser<'a> {
    text: &'a str,
    ring: &'a Ring,
    toks: Vec<(Tok, usize, usize)>,
    pos: usize,
    depth: usize,
}

/// Parses a rational expression in the variables of `ring`.
pub fn parse_rational(ring: &Ring, text: &str) -> Result<RatFunc, ParseError> {
    let toks = lex(text)?;
    let mut p = Parser {
        text,
        ring,
        toks,
        pos: 0,
        depth: 0,
    };
    if matches!(p.peek(), Tok::End) {
        return Err(ParseError::new(text, 0, 1, "expected an expression, found nothing"));
    }
    let v = p.expr()?;
    if !matches!(p.peek(), Tok::End) {
        let (_, o, l) = p.toks[p.pos].clone();
        return Err(ParseError::new(
            text,
            o,
            l,
            "expected an operator or the end of the expression",
        ));
    }
    Ok(v)
}

/// Parses a polynomial (division only by nonzero constants).
pub fn parse_poly(ring: &Ring, text: &str) -> Result<Poly<Rat>, ParseError> {
    let rf = parse_rational(ring, text)?;
    if rf.den.is_constant() {
        let c = rf.den.lc().cloned().unwrap_or_else(Rat::one);
        return Ok(rf.num.scale(&c.recip()));
    }
    Err(ParseError::new(
        text,
        0,
        text.len(),
        "expected a polynomial, but this divides by a non-constant expression",
    ))
}

fn one(ring: &Ring) -> Poly<Rat> {
    Poly::constant(ring, Rat::one())
}

impl Parser<'_> {
    fn peek(&self) -> &Tok {
        &self.toks[self.pos].0
    }
    fn here(&self) -> (usize, usize) {
        (self.toks[self.pos].1, self.toks[self.pos].2)
    }
    fn err(&self, msg: impl Into<String>) -> ParseError {
        let (o, l) = self.here();
        ParseError::new(self.text, o, l, msg)
    }

    fn expr(&mut self) -> Result<RatFunc, ParseError> {
        self.depth += 1;
        if self.depth > 500 {
            return Err(self.err("expression nested too deeply"));
        }
        let mut acc = self.term()?;
        loop {
            let sign = match self.peek() {
                Tok::Op('+') => 1,
                Tok::Op('-') => -1,
                _ => break,
            };
            self.pos += 1;
            let t = self.term()?;
            let r = self.ring;
            acc = if acc.den == t.den {
                // A shared denominator stays as it is.
                let num = if sign > 0 {
                    acc.num.add(r, &t.num)
                } else {
                    acc.num.sub(r, &t.num)
                };
                RatFunc { num, den: acc.den }
            } else {
                let a = acc.num.mul(r, &t.den);
                let b = t.num.mul(r, &acc.den);
                let num = if sign > 0 { a.add(r, &b) } else { a.sub(r, &b) };
                RatFunc {
                    num,
                    den: acc.den.mul(r, &t.den),
                }
            };
        }
        self.depth -= 1;
        Ok(acc)
    }

    fn term(&mut self) -> Result<RatFunc, ParseError> {
        let mut acc = self.unary()?;
        loop {
            let (op, explicit) = match self.peek() {
                Tok::Op('*') => ('*', true),
                Tok::Op('/') => ('/', true),
                Tok::Num(_) | Tok::Ident(_) | Tok::Op('(') => ('*', false),
                _ => break,
            };
            let at = self.here();
            if explicit {
                self.pos += 1;
            }
            let f = self.unary()?;
            let r = self.ring;
            acc = if op == '*' {
                RatFunc {
                    num: acc.num.mul(r, &f.num),
                    den: acc.den.mul(r, &f.den),
                }
            } else {
                if f.num.is_zero() {
                    return Err(ParseError::new(self.text, at.0, at.1, "division by zero"));
                }
                RatFunc {
                    num: acc.num.mul(r, &f.den),
                    den: acc.den.mul(r, &f.num),
                }
            };
        }
        Ok(acc)
    }

    fn unary(&mut self) -> Result<RatFunc, ParseError> {
        match self.peek() {
            Tok::Op('-') => {
                self.pos += 1;
                let v = self.unary()?;
                Ok(RatFunc {
                    num: v.num.neg(),
                    den: v.den,
                })
            }
            Tok::Op('+') => {
                self.pos += 1;
                self.unary()
            }
            _ => self.power(),
        }
    }

    fn power(&mut self) -> Result<RatFunc, ParseError> {
        let base = self.atom()?;
        if !matches!(self.peek(), Tok::Op('^')) {
            return Ok(base);
        }
        self.pos += 1;
        let mut neg = false;
        if matches!(self.peek(), Tok::Op('-')) {
            neg = true;
            self.pos += 1;
        }
        let (o, l) = self.here();
        let e = match self.peek().clone() {
            Tok::Num(n) if n.is_integer() && !n.is_negative() && n.numer() <= &Int::from(10_000) => {
                self.pos += 1;
                n.numer().to_string().parse::<u32>().unwrap_or(0)
            }
            _ => {
                return Err(ParseError::new(
                    self.text,
                    o,
                    l,
                    "expected a whole-number exponent up to 10000 after `^`",
                ))
            }
        };
        let r = self.ring;
        if e == 0 {
            return Ok(RatFunc {
                num: one(r),
                den: one(r),
            });
        }
        let (num, den) = (base.num.pow(r, e), base.den.pow(r, e));
        if neg {
            if num.is_zero() {
                return Err(ParseError::new(self.text, o, l, "zero raised to a negative power"));
            }
            return Ok(RatFunc { num: den, den: num });
        }
        Ok(RatFunc { num, den })
    }

    fn atom(&mut self) -> Result<RatFunc, ParseError> {
        let (tok, o, l) = self.toks[self.pos].clone();
        let r = self.ring;
        match tok {
            Tok::Num(n) => {
                self.pos += 1;
                Ok(RatFunc {
                    num: Poly::constant(r, n),
                    den: one(r),
                })
            }
            Tok::Ident(name) => {
                self.pos += 1;
                let Some(idx) = split_name(r, &name) else {
                    return Err(ParseError::new(
                        self.text,
                        o,
                        l,
                        format!("unknown variable `{name}` (the variables are {})", r.vars().join(", ")),
                    ));
                };
                let mut e = vec![0u16; r.nvars()];
                for i in idx {
                    e[i] += 1;
                }
                Ok(RatFunc {
                    num: Poly::monomial(Monomial::new(&e), Rat::one()),
                    den: one(r),
                })
            }
            Tok::Op('(') => {
                self.pos += 1;
                let v = self.expr()?;
                if !matches!(self.peek(), Tok::Op(')')) {
                    return Err(self.err("expected `)`"));
                }
                self.pos += 1;
                Ok(v)
            }
            Tok::End => Err(ParseError::new(self.text, o, l, "unexpected end of the expression")),
            Tok::Op(c) => Err(ParseError::new(
                self.text,
                o,
                l,
                format!("expected a number, a variable or `(`, found `{c}`"),
            )),
        }
    }
}

/// A variable name, or a juxtaposition of variable names (`st` = s·t), split
/// greedily by the longest known name.
fn split_name(r: &Ring, name: &str) -> Option<Vec<usize>> {
    if let Some(i) = r.index_of(name) {
        return Some(vec![i]);
    }
    let mut out = Vec::new();
    let mut rest = name;
    while !rest.is_empty() {
        let (i, len) = r
            .vars()
            .iter()
            .enumerate()
            .filter(|(_, v)| rest.starts_with(v.as_str()))
            .map(|(i, v)| (i, v.len()))
            .max_by_key(|&(_, l)| l)?;
        out.push(i);
        rest = &rest[len..];
    }
    Some(out)
}

/// The polynomial with integer coefficients obtained by clearing denominators
/// (multiplying by their lcm), made primitive with a positive leading coefficient.
pub fn to_primitive_integer(ring: &Ring, p: &Poly<Rat>) -> Poly<Int> {
    use num_integer::Integer;
    let mut l = Int::one();
    for (_, c) in p.terms() {
        l = l.lcm(c.denom());
    }
    let terms: Vec<_> = p
        .terms()
        .iter()
        .map(|(m, c)| (m.clone(), (c * Rat::from_integer(l.clone())).to_integer()))
        .collect();
    let _ = ring;
    Poly::from_sorted(terms).normalized()
}

/// The polynomial over Q with the same coefficients.
pub fn to_rational(p: &Poly<Int>) -> Poly<Rat> {
    Poly::from_sorted(
        p.terms()
            .iter()
            .map(|(m, c)| (m.clone(), Rat::from_integer(c.clone())))
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::monomial::MonomialOrder;

    #[test]
    fn errors_have_positions() {
        let ring = Ring::new(&["x", "y"], MonomialOrder::DegRevLex);
        let e = parse_poly(&ring, "x^2 + q").unwrap_err();
        assert_eq!((e.offset, e.column), (6, 7));
        assert!(e.message.contains("unknown variable `q`"));
        let e = parse_poly(&ring, "x^2 + (y").unwrap_err();
        assert!(e.message.contains("expected `)`"), "{e}");
        let e = parse_poly(&ring, "x^y").unwrap_err();
        assert!(e.message.contains("exponent"), "{e}");
        let e = parse_poly(&ring, "x/(y-y)").unwrap_err();
        assert!(e.message.contains("division by zero"), "{e}");
        let e = parse_poly(&ring, "x/y").unwrap_err();
        assert!(e.message.contains("expected a polynomial"), "{e}");
        assert!(parse_poly(&ring, "").is_err());
        assert!(parse_poly(&ring, "x $ y").is_err());
        assert!(e.render("x/y").contains('^'));
    }

    #[test]
    fn rational_expressions_and_juxtaposition() {
        let ring = Ring::new(&["s", "t"], MonomialOrder::DegRevLex);
        let f = parse_rational(&ring, "2s/(s^2+t^2+1)").unwrap();
        assert_eq!(f.num, parse_poly(&ring, "2*s").unwrap());
        assert_eq!(f.den, parse_poly(&ring, "s^2 + t^2 + 1").unwrap());
        assert_eq!(
            parse_poly(&ring, "st + 0.5s").unwrap(),
            parse_poly(&ring, "s*t + 1/2*s").unwrap()
        );
        assert_eq!(parse_poly(&ring, "s**2").unwrap(), parse_poly(&ring, "s^2").unwrap());
        let g = parse_rational(&ring, "s^-2").unwrap();
        assert_eq!(g.den, parse_poly(&ring, "s^2").unwrap());
    }
}
