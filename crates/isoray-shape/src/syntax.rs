//! Lexer, abstract syntax tree and parser of the shape language.
//!
//! The grammar, in order of precedence:
//!
//! ```text
//! program  := stmt* [ 'return' ] expr [ ';' ]
//! stmt     := 'let' IDENT [ ':' TYPE ] '=' expr ';'
//!           | TYPE IDENT '=' expr ';'            // GLSL style: vec3 q = p - c;
//! expr     := additive
//! additive := term (('+' | '-') term)*
//! term     := unary (('*' | '/') unary)*
//! unary    := ('-' | '+') unary | power
//! power    := postfix [ '^' unary ]               // right-associative; -x^2 = -(x^2)
//! postfix  := primary ('.' SWIZZLE)*
//! primary  := NUMBER | IDENT | IDENT '(' [expr (',' expr)*] ')' | '(' expr ')'
//! ```
//! Comments are `// ...` to the end of the line and `/* ... */`.

use crate::diag::{Diagnostic, SourceId, Span};

/// A token kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Tok {
    /// A numeric literal.
    Num(f64),
    /// An identifier or keyword.
    Ident(String),
    /// One of `+ - * / ( ) , . ; = :`.
    Punct(char),
    /// End of input.
    Eof,
}

/// A token with its span.
#[derive(Debug, Clone, PartialEq)]
pub struct Token {
    /// What it is.
    pub tok: Tok,
    /// Where it is.
    pub span: Span,
}

/// Splits `text` into tokens.
pub fn lex(text: &str, source: SourceId) -> Result<Vec<Token>, Diagnostic> {
    let bytes = text.as_bytes();
    let mut i = 0;
    let mut out = Vec::new();
    while i < bytes.len() {
        let c = bytes[i];
        if c.is_ascii_whitespace() {
            i += 1;
            continue;
        }
        if c == b'/' && bytes.get(i + 1) == Some(&b'/') {
            while i < bytes.len() && bytes[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c == b'/' && bytes.get(i + 1) == Some(&b'*') {
            let start = i;
            i += 2;
            loop {
                if i + 1 >= bytes.len() {
                    return Err(
                        Diagnostic::new(source, Span::new(start, start + 2), "unterminated comment")
                            .with_label("this `/*` is never closed with `*/`"),
                    );
                }
                if bytes[i] == b'*' && bytes[i + 1] == b'/' {
                    i += 2;
                    break;
                }
                i += 1;
            }
            continue;
        }
        let start = i;
        if c.is_ascii_digit() || (c == b'.' && bytes.get(i + 1).is_some_and(|b| b.is_ascii_digit())) {
            while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
                i += 1;
            }
            if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
                let save = i;
                i += 1;
                if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
                    i += 1;
                }
                if i < bytes.len() && bytes[i].is_ascii_digit() {
                    while i < bytes.len() && bytes[i].is_ascii_digit() {
                        i += 1;
                    }
                } else {
                    i = save;
                }
            }
            // GLSL float suffix.
            let lit = &text[start..i];
            if i < bytes.len() && (bytes[i] == b'f' || bytes[i] == b'F') {
                i += 1;
            }
            let span = Span::new(start, i);
            let v: f64 = lit.parse().map_err(|_| {
                Diagnostic::new(source, span, format!("malformed number `{lit}`"))
                    .with_label("expected a number like 1, 0.5 or 2.5e-3")
            })?;
            out.push(Token { tok: Tok::Num(v), span });
            continue;
        }
        if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            out.push(Token {
                tok: Tok::Ident(text[start..i].to_string()),
                span: Span::new(start, i),
            });
            continue;
        }
        if b"+-*/^(),.;=:".contains(&c) {
            out.push(Token {
                tok: Tok::Punct(c as char),
                span: Span::new(i, i + 1),
            });
            i += 1;
            continue;
        }
        let ch = text[i..].chars().next().unwrap_or('?');
        return Err(Diagnostic::new(
            source,
            Span::new(i, i + ch.len_utf8()),
            format!("unexpected character `{ch}`"),
        )
        .with_label("not part of the shape language"));
    }
    out.push(Token {
        tok: Tok::Eof,
        span: Span::new(text.len(), text.len()),
    });
    Ok(out)
}

/// A binary arithmetic operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BinaryOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^` (power, right-associative, binds tighter than unary minus: -x^2 = -(x^2))
    Pow,
}

impl BinaryOp {
    /// The operator's symbol.
    pub fn symbol(self) -> char {
        match self {
            BinaryOp::Add => '+',
            BinaryOp::Sub => '-',
            BinaryOp::Mul => '*',
            BinaryOp::Div => '/',
            BinaryOp::Pow => '^',
        }
    }
}

/// An expression node.
#[derive(Debug, Clone, PartialEq)]
pub enum ExprKind {
    /// A literal.
    Num(f64),
    /// A variable: `p`, a parameter or a `let` binding.
    Var(String),
    /// A call of a built-in, primitive, operator or user surface.
    Call {
        /// The callee's name.
        name: String,
        /// Span of the name.
        name_span: Span,
        /// Arguments in order.
        args: Vec<Expr>,
    },
    /// `a op b`.
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// `-a`.
    Neg(Box<Expr>),
    /// `a.xzy`.
    Swizzle(Box<Expr>, String),
}

/// An expression with its span.
#[derive(Debug, Clone, PartialEq)]
pub struct Expr {
    /// What it is.
    pub kind: ExprKind,
    /// The text it covers.
    pub span: Span,
}

/// A type annotation as written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TypeName {
    /// `float`
    Float,
    /// `vec2`
    Vec2,
    /// `vec3`
    Vec3,
}

impl TypeName {
    fn from_ident(s: &str) -> Option<TypeName> {
        match s {
            "float" => Some(TypeName::Float),
            "vec2" => Some(TypeName::Vec2),
            "vec3" => Some(TypeName::Vec3),
            _ => None,
        }
    }
}

/// `let name [: type] = value;`
#[derive(Debug, Clone, PartialEq)]
pub struct Let {
    /// Bound name.
    pub name: String,
    /// Span of the name.
    pub name_span: Span,
    /// Optional declared type.
    pub ty: Option<(TypeName, Span)>,
    /// Bound expression.
    pub value: Expr,
}

/// A parsed snippet: bindings then a result expression.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    /// The `let` bindings, in order.
    pub lets: Vec<Let>,
    /// The result.
    pub body: Expr,
}

impl Program {
    /// The names of the functions it calls, in order of first appearance.
    pub fn functions_called(&self) -> Vec<String> {
        fn walk(e: &Expr, out: &mut Vec<String>) {
            match &e.kind {
                ExprKind::Num(_) | ExprKind::Var(_) => {}
                ExprKind::Call { name, args, .. } => {
                    if !out.contains(name) {
                        out.push(name.clone());
                    }
                    args.iter().for_each(|a| walk(a, out));
                }
                ExprKind::Binary(_, a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                ExprKind::Neg(a) | ExprKind::Swizzle(a, _) => walk(a, out),
            }
        }
        let mut out = Vec::new();
        for l in &self.lets {
            walk(&l.value, &mut out);
        }
        walk(&self.body, &mut out);
        out
    }

    /// Every variable name the program reads (bindings included).
    pub fn names_used(&self) -> std::collections::BTreeSet<String> {
        fn walk(e: &Expr, out: &mut std::collections::BTreeSet<String>) {
            match &e.kind {
                ExprKind::Num(_) => {}
                ExprKind::Var(n) => {
                    out.insert(n.clone());
                }
                ExprKind::Call { args, .. } => args.iter().for_each(|a| walk(a, out)),
                ExprKind::Binary(_, a, b) => {
                    walk(a, out);
                    walk(b, out);
                }
                ExprKind::Neg(a) | ExprKind::Swizzle(a, _) => walk(a, out),
            }
        }
        let mut out = std::collections::BTreeSet::new();
        for l in &self.lets {
            walk(&l.value, &mut out);
        }
        walk(&self.body, &mut out);
        out
    }
}

/// Words that cannot be used as binding names.
pub const KEYWORDS: &[&str] = &["let", "return", "float", "vec2", "vec3"];

struct Parser<'a> {
    toks: &'a [Token],
    pos: usize,
    source: SourceId,
    depth: usize,
}

/// Maximum nesting depth, so that hostile input cannot overflow the stack.
const MAX_DEPTH: usize = 200;

/// Maximum length of a chain of binary operators (`a + b + c + ...`), which
/// parses into a left-deep tree that later passes walk recursively.
const MAX_CHAIN: usize = 2000;

/// Parses a snippet of shape text.
pub fn parse(text: &str, source: SourceId) -> Result<Program, Diagnostic> {
    let toks = lex(text, source)?;
    let mut p = Parser {
        toks: &toks,
        pos: 0,
        source,
        depth: 0,
    };
    p.program()
}

fn describe(t: &Tok) -> String {
    match t {
        Tok::Num(v) => format!("number `{v}`"),
        Tok::Ident(s) => format!("`{s}`"),
        Tok::Punct(c) => format!("`{c}`"),
        Tok::Eof => "end of input".to_string(),
    }
}

impl Parser<'_> {
    fn peek(&self) -> &Token {
        &self.toks[self.pos.min(self.toks.len() - 1)]
    }
    fn peek_at(&self, k: usize) -> &Tok {
        &self.toks[(self.pos + k).min(self.toks.len() - 1)].tok
    }
    fn bump(&mut self) -> Token {
        let t = self.peek().clone();
        if self.pos < self.toks.len() - 1 {
            self.pos += 1;
        }
        t
    }
    fn err(&self, msg: impl Into<String>, label: impl Into<String>) -> Diagnostic {
        Diagnostic::new(self.source, self.peek().span, msg).with_label(label)
    }
    fn expect_punct(&mut self, c: char, context: &str) -> Result<Span, Diagnostic> {
        if self.peek().tok == Tok::Punct(c) {
            Ok(self.bump().span)
        } else {
            let found = describe(&self.peek().tok);
            Err(self.err(
                format!("expected `{c}` {context}, found {found}"),
                format!("expected `{c}`"),
            ))
        }
    }
    fn is_punct(&self, c: char) -> bool {
        self.peek().tok == Tok::Punct(c)
    }

    fn program(&mut self) -> Result<Program, Diagnostic> {
        let mut lets = Vec::new();
        loop {
            let is_let = matches!(&self.peek().tok, Tok::Ident(s) if s == "let");
            let is_decl = matches!(&self.peek().tok, Tok::Ident(s) if TypeName::from_ident(s).is_some())
                && matches!(self.peek_at(1), Tok::Ident(_));
            if !(is_let || is_decl) {
                break;
            }
            let ty = if is_let {
                self.bump();
                None
            } else {
                let t = self.bump();
                let Tok::Ident(s) = &t.tok else { unreachable!() };
                TypeName::from_ident(s).map(|ty| (ty, t.span))
            };
            let name_tok = self.bump();
            let Tok::Ident(name) = name_tok.tok else {
                return Err(Diagnostic::new(
                    self.source,
                    name_tok.span,
                    format!("expected a name after `let`, found {}", describe(&name_tok.tok)),
                )
                .with_label("expected a name"));
            };
            if KEYWORDS.contains(&name.as_str()) || name == "p" {
                return Err(Diagnostic::new(
                    self.source,
                    name_tok.span,
                    format!("`{name}` is reserved and cannot be bound"),
                )
                .with_label("reserved name"));
            }
            let mut ty = ty;
            if is_let && self.is_punct(':') {
                self.bump();
                let t = self.bump();
                match &t.tok {
                    Tok::Ident(s) if TypeName::from_ident(s).is_some() => {
                        ty = TypeName::from_ident(s).map(|x| (x, t.span))
                    }
                    other => {
                        return Err(Diagnostic::new(
                            self.source,
                            t.span,
                            format!("expected a type (`float`, `vec2` or `vec3`), found {}", describe(other)),
                        )
                        .with_label("expected a type"))
                    }
                }
            }
            self.expect_punct('=', &format!("after the name `{name}`"))?;
            let value = self.expr()?;
            self.expect_punct(';', "after the bound expression")?;
            lets.push(Let {
                name,
                name_span: name_tok.span,
                ty,
                value,
            });
        }
        if matches!(&self.peek().tok, Tok::Ident(s) if s == "return") {
            self.bump();
        }
        if self.peek().tok == Tok::Eof {
            return Err(self.err(
                "expected an expression, found end of input",
                "the shape needs a final expression giving the distance",
            ));
        }
        let body = self.expr()?;
        if self.is_punct(';') {
            self.bump();
        }
        if self.peek().tok != Tok::Eof {
            let found = describe(&self.peek().tok);
            return Err(self.err(
                format!("expected end of input after the expression, found {found}"),
                "unexpected text",
            ));
        }
        Ok(Program { lets, body })
    }

    fn expr(&mut self) -> Result<Expr, Diagnostic> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err("expression nested too deeply", format!("more than {MAX_DEPTH} levels")));
        }
        let r = self.additive();
        self.depth -= 1;
        r
    }

    fn additive(&mut self) -> Result<Expr, Diagnostic> {
        self.binary_level(Self::term, |t| match t {
            Tok::Punct('+') => Some(BinaryOp::Add),
            Tok::Punct('-') => Some(BinaryOp::Sub),
            _ => None,
        })
    }

    fn term(&mut self) -> Result<Expr, Diagnostic> {
        self.binary_level(Self::unary, |t| match t {
            Tok::Punct('*') => Some(BinaryOp::Mul),
            Tok::Punct('/') => Some(BinaryOp::Div),
            _ => None,
        })
    }

    /// One left-associative precedence level: `operand (op operand)*`.
    fn binary_level(
        &mut self,
        operand: fn(&mut Self) -> Result<Expr, Diagnostic>,
        op_of: fn(&Tok) -> Option<BinaryOp>,
    ) -> Result<Expr, Diagnostic> {
        let mut lhs = operand(self)?;
        let mut chain = 0;
        while let Some(op) = op_of(&self.peek().tok) {
            chain += 1;
            if chain > MAX_CHAIN {
                return Err(self.err(
                    "expression too long",
                    format!("more than {MAX_CHAIN} operators in a row; use `let` bindings"),
                ));
            }
            self.bump();
            let rhs = operand(self)?;
            let span = lhs.span.to(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
        }
        Ok(lhs)
    }

    fn unary(&mut self) -> Result<Expr, Diagnostic> {
        if self.is_punct('-') || self.is_punct('+') {
            let t = self.bump();
            self.depth += 1;
            if self.depth > MAX_DEPTH {
                return Err(self.err("expression nested too deeply", format!("more than {MAX_DEPTH} levels")));
            }
            let inner = self.unary()?;
            self.depth -= 1;
            let span = t.span.to(inner.span);
            if t.tok == Tok::Punct('+') {
                return Ok(Expr { kind: inner.kind, span });
            }
            return Ok(Expr {
                kind: ExprKind::Neg(Box::new(inner)),
                span,
            });
        }
        self.power()
    }

    /// `postfix ('^' unary)?`, right-associative through `unary`.
    fn power(&mut self) -> Result<Expr, Diagnostic> {
        let base = self.postfix()?;
        if !self.is_punct('^') {
            return Ok(base);
        }
        self.bump();
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err("expression nested too deeply", format!("more than {MAX_DEPTH} levels")));
        }
        let exp = self.unary()?;
        self.depth -= 1;
        let span = base.span.to(exp.span);
        Ok(Expr {
            kind: ExprKind::Binary(BinaryOp::Pow, Box::new(base), Box::new(exp)),
            span,
        })
    }

    fn postfix(&mut self) -> Result<Expr, Diagnostic> {
        let mut e = self.primary()?;
        while self.is_punct('.') {
            self.bump();
            let t = self.bump();
            match t.tok {
                Tok::Ident(s) => {
                    let span = e.span.to(t.span);
                    e = Expr {
                        kind: ExprKind::Swizzle(Box::new(e), s),
                        span,
                    };
                }
                other => {
                    return Err(Diagnostic::new(
                        self.source,
                        t.span,
                        format!("expected a swizzle such as `.xz` after `.`, found {}", describe(&other)),
                    )
                    .with_label("expected components"))
                }
            }
        }
        Ok(e)
    }

    fn primary(&mut self) -> Result<Expr, Diagnostic> {
        let t = self.bump();
        match t.tok {
            Tok::Num(v) => Ok(Expr {
                kind: ExprKind::Num(v),
                span: t.span,
            }),
            Tok::Ident(name) => {
                if self.is_punct('(') {
                    self.bump();
                    let mut args = Vec::new();
                    if !self.is_punct(')') {
                        loop {
                            args.push(self.expr()?);
                            if self.is_punct(',') {
                                self.bump();
                                continue;
                            }
                            break;
                        }
                    }
                    let close = self.expect_punct(')', &format!("to close the arguments of `{name}`"))?;
                    Ok(Expr {
                        kind: ExprKind::Call {
                            name,
                            name_span: t.span,
                            args,
                        },
                        span: t.span.to(close),
                    })
                } else {
                    Ok(Expr {
                        kind: ExprKind::Var(name),
                        span: t.span,
                    })
                }
            }
            Tok::Punct('(') => {
                let inner = self.expr()?;
                let close = self.expect_punct(')', "to close the parenthesis")?;
                Ok(Expr {
                    kind: inner.kind,
                    span: t.span.to(close),
                })
            }
            other => Err(Diagnostic::new(
                self.source,
                t.span,
                format!("expected an expression, found {}", describe(&other)),
            )
            .with_label("expected a number, a name, a call or `(`")),
        }
    }
}

/// Binding strength of an expression's outermost operator, as the parser
/// reads it: sums bind loosest, then products, prefix minus, powers, and
/// postfix swizzles, calls, names and numbers tightest.
pub fn precedence(e: &Expr) -> u8 {
    match &e.kind {
        ExprKind::Binary(BinaryOp::Add | BinaryOp::Sub, ..) => 1,
        ExprKind::Binary(BinaryOp::Mul | BinaryOp::Div, ..) => 2,
        ExprKind::Neg(_) => 3,
        ExprKind::Binary(BinaryOp::Pow, ..) => 4,
        _ => 5,
    }
}

/// A number as shape text: the shortest decimal that reads back as the
/// same `f64`, with a `.0` on whole numbers (`1.0`, `0.25`, `1e-7`).
pub fn number_text(v: f64) -> String {
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E']) || !v.is_finite() {
        s
    } else {
        format!("{s}.0")
    }
}

/// Writes `e` as shape text that parses back to the same expression
/// (spans aside), with parentheses only where the grammar needs them.
///
/// ```
/// use isoray_shape::syntax::{parse, print_expr};
/// let p = parse("sphere((p - vec3(1, 0, 0)) * 2.0, 1) + -x^2", 0).unwrap();
/// assert_eq!(print_expr(&p.body), "sphere((p - vec3(1.0, 0.0, 0.0)) * 2.0, 1.0) + -x ^ 2.0");
/// ```
pub fn print_expr(e: &Expr) -> String {
    let mut out = String::new();
    write_expr(&mut out, e, 0);
    out
}

/// Writes `e` as [`print_expr`] does, in parentheses when it binds more
/// loosely than `min` (a [`precedence`] level).
pub fn print_expr_at(e: &Expr, min: u8) -> String {
    let mut out = String::new();
    write_expr(&mut out, e, min);
    out
}

fn write_expr(out: &mut String, e: &Expr, min: u8) {
    let prec = precedence(e);
    let paren = prec < min;
    if paren {
        out.push('(');
    }
    match &e.kind {
        ExprKind::Num(v) => out.push_str(&number_text(*v)),
        ExprKind::Var(n) => out.push_str(n),
        ExprKind::Call { name, args, .. } => {
            out.push_str(name);
            out.push('(');
            for (i, a) in args.iter().enumerate() {
                if i > 0 {
                    out.push_str(", ");
                }
                write_expr(out, a, 0);
            }
            out.push(')');
        }
        ExprKind::Binary(op, a, b) => {
            // Left-associative levels: the right operand must bind tighter.
            // `^` is right-associative: its base is a postfix expression and
            // its exponent a prefix one.
            let (l, r) = match op {
                BinaryOp::Add | BinaryOp::Sub => (1, 2),
                BinaryOp::Mul | BinaryOp::Div => (2, 3),
                BinaryOp::Pow => (5, 3),
            };
            write_expr(out, a, l);
            out.push(' ');
            out.push(op.symbol());
            out.push(' ');
            write_expr(out, b, r);
        }
        ExprKind::Neg(a) => {
            out.push('-');
            write_expr(out, a, 3);
        }
        ExprKind::Swizzle(a, s) => {
            write_expr(out, a, 5);
            out.push('.');
            out.push_str(s);
        }
    }
    if paren {
        out.push(')');
    }
}

impl Program {
    /// The program as shape text ([`print_expr`] for each part), one
    /// `let` per line; comments and layout are not kept.
    pub fn to_text(&self) -> String {
        let mut out = String::new();
        for l in &self.lets {
            out.push_str("let ");
            out.push_str(&l.name);
            if let Some((ty, _)) = l.ty {
                out.push_str(match ty {
                    TypeName::Float => ": float",
                    TypeName::Vec2 => ": vec2",
                    TypeName::Vec3 => ": vec3",
                });
            }
            out.push_str(" = ");
            write_expr(&mut out, &l.value, 0);
            out.push_str(";\n");
        }
        write_expr(&mut out, &self.body, 0);
        out
    }
}

/// `e` with every span set to the empty span at 0, so that two parses of
/// differently laid-out text compare equal when they mean the same.
pub fn without_spans(e: &Expr) -> Expr {
    let kind = match &e.kind {
        ExprKind::Num(v) => ExprKind::Num(*v),
        ExprKind::Var(n) => ExprKind::Var(n.clone()),
        ExprKind::Call { name, args, .. } => ExprKind::Call {
            name: name.clone(),
            name_span: Span::default(),
            args: args.iter().map(without_spans).collect(),
        },
        ExprKind::Binary(op, a, b) => ExprKind::Binary(*op, Box::new(without_spans(a)), Box::new(without_spans(b))),
        ExprKind::Neg(a) => ExprKind::Neg(Box::new(without_spans(a))),
        ExprKind::Swizzle(a, s) => ExprKind::Swizzle(Box::new(without_spans(a)), s.clone()),
    };
    Expr {
        kind,
        span: Span::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn printing_reads_back_to_the_same_expression() {
        let cases = [
            "1 - (2 - 3)",
            "(1 - 2) - 3",
            "a / (b * c)",
            "-x ^ 2",
            "(-x) ^ 2",
            "x ^ y ^ z",
            "(x ^ y) ^ z",
            "x ^ -y",
            "-(a + b) * c",
            "a - -b",
            "(p - vec3(1, 2, 3)).xz",
            "-p.x",
            "sphere(rotate_y(p - vec3(0.3, 0.45, -0.5), 0.6), 1e-7) * 2.5e10",
            "min(a, b) + max(c, -d) / 3",
        ];
        for text in cases {
            let e = parse(text, 0).unwrap().body;
            let printed = print_expr(&e);
            let again = parse(&printed, 0).unwrap().body;
            assert_eq!(without_spans(&again), without_spans(&e), "{text} printed as {printed}");
            assert_eq!(print_expr(&again), printed, "printing is stable for {text}");
        }
        assert_eq!(print_expr(&parse("(a - b) - c", 0).unwrap().body), "a - b - c");
        assert_eq!(print_expr(&parse("a - (b - c)", 0).unwrap().body), "a - (b - c)");
        assert_eq!(print_expr(&parse("(-x)^2", 0).unwrap().body), "(-x) ^ 2.0");
        assert_eq!(number_text(0.95), "0.95");
        assert_eq!(number_text(-2.0), "-2.0");
    }

    #[test]
    fn programs_print_their_bindings() {
        let p = parse("let s = 2.8; vec3 q = p * s;\nsphere(q, 1) / s", 0).unwrap();
        let text = p.to_text();
        assert_eq!(text, "let s = 2.8;\nlet q: vec3 = p * s;\nsphere(q, 1.0) / s");
        let again = parse(&text, 0).unwrap();
        assert_eq!(without_spans(&again.body), without_spans(&p.body));
    }

    #[test]
    fn parses_precedence() {
        let p = parse("1 + 2 * 3", 0).unwrap();
        match p.body.kind {
            ExprKind::Binary(BinaryOp::Add, _, r) => {
                assert!(matches!(r.kind, ExprKind::Binary(BinaryOp::Mul, _, _)))
            }
            k => panic!("{k:?}"),
        }
    }

    #[test]
    fn parses_lets_and_swizzles() {
        let p = parse(
            "let q = p.xz; // comment\n vec2 r = q * 2.0; /* block */ length(r) - 1.0",
            0,
        )
        .unwrap();
        assert_eq!(p.lets.len(), 2);
        assert_eq!(p.lets[1].ty.map(|t| t.0), Some(TypeName::Vec2));
    }

    #[test]
    fn power_binds_tighter_than_minus_and_is_right_associative() {
        let p = parse("-x^2", 0).unwrap();
        assert!(matches!(p.body.kind, ExprKind::Neg(ref e) if matches!(e.kind, ExprKind::Binary(BinaryOp::Pow, _, _))));
        let p = parse("2^3^2", 0).unwrap();
        match p.body.kind {
            ExprKind::Binary(BinaryOp::Pow, l, r) => {
                assert_eq!(l.kind, ExprKind::Num(2.0));
                assert!(matches!(r.kind, ExprKind::Binary(BinaryOp::Pow, _, _)));
            }
            k => panic!("{k:?}"),
        }
    }

    #[test]
    fn numbers() {
        let toks = lex("1 .5 2.5e-3 1e2 3.0f", 0).unwrap();
        let v: Vec<f64> = toks
            .iter()
            .filter_map(|t| if let Tok::Num(v) = t.tok { Some(v) } else { None })
            .collect();
        assert_eq!(v, vec![1.0, 0.5, 2.5e-3, 100.0, 3.0]);
    }

    #[test]
    fn errors_are_located() {
        let e = parse("sphere(p, 1.0", 0).unwrap_err();
        assert_eq!(e.span.start, 13);
        assert!(e.message.contains("expected `)`"), "{}", e.message);
        let e = parse("1 + $", 0).unwrap_err();
        assert_eq!(e.span, Span::new(4, 5));
        let e = parse("", 0).unwrap_err();
        assert!(e.message.contains("expected an expression"));
    }

    #[test]
    fn deep_nesting_is_an_error_not_a_crash() {
        let s = "(".repeat(10_000) + "1" + &")".repeat(10_000);
        assert!(parse(&s, 0).is_err());
        let s = "-".repeat(10_000) + "1";
        assert!(parse(&s, 0).is_err());
        let s = vec!["1.0"; 100_000].join(" + ");
        assert!(parse(&s, 0).is_err());
        let s = vec!["p.x"; 500].join(" * ");
        assert!(parse(&s, 0).is_ok());
    }
}
