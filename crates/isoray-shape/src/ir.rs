//! The shape IR: a hash-consed DAG of scalar operations.
//!
//! The typed language (floats and vectors) is lowered to scalars here; a
//! vector is just two or three nodes. Every node is created through
//! [`Builder`], which folds constants, applies a few algebraic identities and
//! shares identical subexpressions, so that each distinct computation appears
//! once. [`Builder::tape`] then extracts the nodes one output needs, in
//! evaluation order, with slots allocated for a small working set.

use std::collections::HashMap;
use std::sync::Arc;

/// The input index of the time `t` (seconds): the first entry of every
/// variable slice. Scene parameters follow it.
pub const TIME: u32 = 0;

/// A node of the DAG (an index into the builder).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Node(pub u32);

/// One-argument operations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum UnOp {
    /// −x
    Neg,
    /// |x|
    Abs,
    /// √x
    Sqrt,
    /// x²
    Square,
    /// sin x
    Sin,
    /// cos x
    Cos,
    /// tan x
    Tan,
    /// asin x
    Asin,
    /// acos x
    Acos,
    /// atan x
    Atan,
    /// eˣ
    Exp,
    /// ln x
    Ln,
    /// ⌊x⌋
    Floor,
    /// nearest integer, halves away from zero
    Round,
    /// −1, 0 or 1
    Sign,
}

/// Two-argument operations.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum BinOp {
    /// a + b
    Add,
    /// a − b
    Sub,
    /// a · b
    Mul,
    /// a / b
    Div,
    /// min(a, b)
    Min,
    /// max(a, b)
    Max,
    /// aᵇ
    Pow,
    /// atan2(a, b) = atan(a / b) in the right quadrant
    Atan2,
}

/// An operation of the DAG.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// A constant.
    Const(f64),
    /// The x coordinate of the evaluated point.
    X,
    /// The y coordinate.
    Y,
    /// The z coordinate.
    Z,
    /// A runtime input: the time ([`TIME`]) or a scene parameter, by its
    /// index in the caller's variable slice (see [`Tape::vars`]).
    Input(u32),
    /// A unary operation.
    Unary(UnOp, Node),
    /// A binary operation.
    Binary(BinOp, Node, Node),
    /// `if c > 0 { a } else { b }`
    Select(Node, Node, Node),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum Key {
    Const(u64),
    X,
    Y,
    Z,
    Input(u32),
    Unary(UnOp, Node),
    Binary(BinOp, Node, Node),
    Select(Node, Node, Node),
}

impl Op {
    fn key(&self) -> Key {
        match *self {
            Op::Const(v) => Key::Const(v.to_bits()),
            Op::X => Key::X,
            Op::Y => Key::Y,
            Op::Z => Key::Z,
            Op::Input(v) => Key::Input(v),
            Op::Unary(o, a) => Key::Unary(o, a),
            Op::Binary(o, a, b) => Key::Binary(o, a, b),
            Op::Select(c, a, b) => Key::Select(c, a, b),
        }
    }
}

/// Applies a unary operation to a number (the reference semantics every
/// evaluator follows, in f32 or f64).
#[inline(always)]
pub fn apply_unary<T: num_traits::Float>(op: UnOp, x: T) -> T {
    match op {
        UnOp::Neg => -x,
        UnOp::Abs => x.abs(),
        UnOp::Sqrt => x.sqrt(),
        UnOp::Square => x * x,
        UnOp::Sin => x.sin(),
        UnOp::Cos => x.cos(),
        UnOp::Tan => x.tan(),
        UnOp::Asin => x.asin(),
        UnOp::Acos => x.acos(),
        UnOp::Atan => x.atan(),
        UnOp::Exp => x.exp(),
        UnOp::Ln => x.ln(),
        UnOp::Floor => x.floor(),
        UnOp::Round => x.round(),
        UnOp::Sign => sign(x),
    }
}

/// GLSL `sign`: −1, 0 or 1 (NaN stays NaN).
#[inline(always)]
pub fn sign<T: num_traits::Float>(x: T) -> T {
    if x > T::zero() {
        T::one()
    } else if x < T::zero() {
        -T::one()
    } else {
        x
    }
}

/// Applies a binary operation to numbers.
#[inline(always)]
pub fn apply_binary<T: num_traits::Float>(op: BinOp, a: T, b: T) -> T {
    match op {
        BinOp::Add => a + b,
        BinOp::Sub => a - b,
        BinOp::Mul => a * b,
        BinOp::Div => a / b,
        BinOp::Min => a.min(b),
        BinOp::Max => a.max(b),
        BinOp::Pow => a.powf(b),
        BinOp::Atan2 => a.atan2(b),
    }
}

/// Builds the DAG. Identical operations on identical operands are created
/// once; operations on constants are folded.
#[derive(Debug, Default, Clone)]
pub struct Builder {
    ops: Vec<Op>,
    /// Each operation's node (hashed with FxHash: interning is most of
    /// what building a large scene's graph costs).
    dedup: rustc_hash::FxHashMap<Key, Node>,
    /// Selects whose `b` operand may be skipped (see [`Builder::lazy_select`]).
    lazy: rustc_hash::FxHashSet<Node>,
}

impl Builder {
    /// An empty builder.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of distinct nodes so far.
    pub fn len(&self) -> usize {
        self.ops.len()
    }

    /// True when no node exists yet.
    pub fn is_empty(&self) -> bool {
        self.ops.is_empty()
    }

    /// The operation of a node.
    pub fn op(&self, n: Node) -> Op {
        self.ops[n.0 as usize]
    }

    /// The value of a node if it is a constant.
    pub fn const_value(&self, n: Node) -> Option<f64> {
        match self.op(n) {
            Op::Const(v) => Some(v),
            _ => None,
        }
    }

    fn intern(&mut self, op: Op) -> Node {
        let key = op.key();
        if let Some(&n) = self.dedup.get(&key) {
            return n;
        }
        let n = Node(self.ops.len() as u32);
        self.ops.push(op);
        self.dedup.insert(key, n);
        n
    }

    /// A constant.
    pub fn constant(&mut self, v: f64) -> Node {
        self.intern(Op::Const(v))
    }
    /// The point's x.
    pub fn x(&mut self) -> Node {
        self.intern(Op::X)
    }
    /// The point's y.
    pub fn y(&mut self) -> Node {
        self.intern(Op::Y)
    }
    /// The point's z.
    pub fn z(&mut self) -> Node {
        self.intern(Op::Z)
    }
    /// A runtime input (the time [`TIME`] or a parameter), read from the
    /// variable slice an evaluator is given on each call.
    pub fn input(&mut self, var: u32) -> Node {
        self.intern(Op::Input(var))
    }

    /// True when `n` depends on no coordinate: it is the same at every point
    /// (a constant, an input, or an operation on such).
    pub fn is_uniform(&self, n: Node) -> bool {
        let mut memo = HashMap::new();
        self.uniform_memo(n, &mut memo)
    }

    fn uniform_memo(&self, n: Node, memo: &mut HashMap<Node, bool>) -> bool {
        if let Some(&u) = memo.get(&n) {
            return u;
        }
        let u = match self.op(n) {
            Op::Const(_) | Op::Input(_) => true,
            Op::X | Op::Y | Op::Z => false,
            Op::Unary(_, a) => self.uniform_memo(a, memo),
            Op::Binary(_, a, b) => self.uniform_memo(a, memo) && self.uniform_memo(b, memo),
            Op::Select(c, a, b) => {
                self.uniform_memo(c, memo) && self.uniform_memo(a, memo) && self.uniform_memo(b, memo)
            }
        };
        memo.insert(n, u);
        u
    }

    /// The inputs `n` depends on, sorted.
    pub fn inputs_of(&self, n: Node) -> Vec<u32> {
        let mut seen = std::collections::HashSet::new();
        let mut stack = vec![n];
        let mut out = Vec::new();
        while let Some(m) = stack.pop() {
            if !seen.insert(m) {
                continue;
            }
            match self.op(m) {
                Op::Input(v) => out.push(v),
                Op::Unary(_, a) => stack.push(a),
                Op::Binary(_, a, b) => stack.extend([a, b]),
                Op::Select(c, a, b) => stack.extend([c, a, b]),
                _ => {}
            }
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The value of a uniform node (see [`Builder::is_uniform`]) for the
    /// given inputs, in f64 exactly as a tape's prologue computes it; `None`
    /// when the node depends on a coordinate.
    pub fn uniform_value(&self, n: Node, vars: &[f64]) -> Option<f64> {
        let mut memo = HashMap::new();
        self.value_memo(n, vars, &mut memo)
    }

    fn value_memo(&self, n: Node, vars: &[f64], memo: &mut HashMap<Node, Option<f64>>) -> Option<f64> {
        if let Some(&v) = memo.get(&n) {
            return v;
        }
        let v = match self.op(n) {
            Op::Const(v) => Some(v),
            Op::Input(k) => Some(vars.get(k as usize).copied().unwrap_or(f64::NAN)),
            Op::X | Op::Y | Op::Z => None,
            Op::Unary(op, a) => self.value_memo(a, vars, memo).map(|x| apply_unary(op, x)),
            Op::Binary(op, a, b) => {
                let x = self.value_memo(a, vars, memo)?;
                let y = self.value_memo(b, vars, memo)?;
                Some(apply_binary(op, x, y))
            }
            Op::Select(c, a, b) => {
                let cv = self.value_memo(c, vars, memo)?;
                let av = self.value_memo(a, vars, memo)?;
                let bv = self.value_memo(b, vars, memo)?;
                Some(if cv > 0.0 { av } else { bv })
            }
        };
        memo.insert(n, v);
        v
    }

    /// A unary operation, folded when its operand is constant.
    pub fn unary(&mut self, op: UnOp, a: Node) -> Node {
        if let Some(v) = self.const_value(a) {
            return self.constant(apply_unary(op, v));
        }
        match (op, self.op(a)) {
            (UnOp::Neg, Op::Unary(UnOp::Neg, inner)) => return inner,
            (UnOp::Abs, Op::Unary(UnOp::Abs | UnOp::Square | UnOp::Sqrt | UnOp::Exp, _)) => return a,
            (UnOp::Abs, Op::Unary(UnOp::Neg, inner)) => return self.unary(UnOp::Abs, inner),
            (UnOp::Square, Op::Unary(UnOp::Neg | UnOp::Abs, inner)) => return self.unary(UnOp::Square, inner),
            _ => {}
        }
        self.intern(Op::Unary(op, a))
    }

    /// A binary operation, folded and simplified where that is exact.
    pub fn binary(&mut self, op: BinOp, a: Node, b: Node) -> Node {
        let (ca, cb) = (self.const_value(a), self.const_value(b));
        if let (Some(x), Some(y)) = (ca, cb) {
            return self.constant(apply_binary(op, x, y));
        }
        match op {
            BinOp::Add => {
                if ca == Some(0.0) {
                    return b;
                }
                if cb == Some(0.0) {
                    return a;
                }
                if let Op::Unary(UnOp::Neg, nb) = self.op(b) {
                    return self.binary(BinOp::Sub, a, nb);
                }
            }
            BinOp::Sub => {
                if cb == Some(0.0) {
                    return a;
                }
                if ca == Some(0.0) {
                    return self.unary(UnOp::Neg, b);
                }
                if let Op::Unary(UnOp::Neg, nb) = self.op(b) {
                    return self.binary(BinOp::Add, a, nb);
                }
            }
            BinOp::Mul => {
                if ca == Some(1.0) {
                    return b;
                }
                if cb == Some(1.0) {
                    return a;
                }
                if ca == Some(-1.0) {
                    return self.unary(UnOp::Neg, b);
                }
                if cb == Some(-1.0) {
                    return self.unary(UnOp::Neg, a);
                }
                if a == b {
                    return self.unary(UnOp::Square, a);
                }
            }
            BinOp::Div => {
                if cb == Some(1.0) {
                    return a;
                }
                // Division by a constant power of two is exact as a multiplication.
                if let Some(y) = cb {
                    let r = 1.0 / y;
                    if y != 0.0 && r.is_finite() && (r * y == 1.0) && y.abs().log2().fract() == 0.0 {
                        let rc = self.constant(r);
                        return self.binary(BinOp::Mul, a, rc);
                    }
                }
            }
            BinOp::Min | BinOp::Max => {
                if a == b {
                    return a;
                }
            }
            BinOp::Pow => {
                if cb == Some(1.0) {
                    return a;
                }
                if cb == Some(2.0) {
                    return self.unary(UnOp::Square, a);
                }
                if cb == Some(0.5) {
                    return self.unary(UnOp::Sqrt, a);
                }
            }
            BinOp::Atan2 => {}
        }
        // Canonical operand order for commutative operations improves sharing.
        let (a, b) = match op {
            BinOp::Add | BinOp::Mul | BinOp::Min | BinOp::Max if b < a => (b, a),
            _ => (a, b),
        };
        self.intern(Op::Binary(op, a, b))
    }

    /// `if c > 0 { a } else { b }`, folded when `c` is constant.
    pub fn select(&mut self, c: Node, a: Node, b: Node) -> Node {
        if let Some(v) = self.const_value(c) {
            return if v > 0.0 { a } else { b };
        }
        if a == b {
            return a;
        }
        self.intern(Op::Select(c, a, b))
    }

    /// `if c > 0 { a } else { b }` where `b` is expensive and `a` cheap: the
    /// tape computes `b` only where some point needs it. In a tape, the nodes
    /// that only `b` uses are placed after a [`Instr::Skip`] that jumps over
    /// them when `c > 0` at every point being evaluated (a bounding volume:
    /// `c` is the distance to it minus a margin, `a` the distance to it).
    pub fn lazy_select(&mut self, c: Node, a: Node, b: Node) -> Node {
        let n = self.select(c, a, b);
        if matches!(self.op(n), Op::Select(..)) {
            self.lazy.insert(n);
        }
        n
    }

    /// Shorthands.
    pub fn add(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Add, a, b)
    }
    /// a − b
    pub fn sub(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Sub, a, b)
    }
    /// a · b
    pub fn mul(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Mul, a, b)
    }
    /// a / b
    pub fn div(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Div, a, b)
    }
    /// min(a, b)
    pub fn min(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Min, a, b)
    }
    /// max(a, b)
    pub fn max(&mut self, a: Node, b: Node) -> Node {
        self.binary(BinOp::Max, a, b)
    }
    /// −a
    pub fn neg(&mut self, a: Node) -> Node {
        self.unary(UnOp::Neg, a)
    }
    /// |a|
    pub fn abs(&mut self, a: Node) -> Node {
        self.unary(UnOp::Abs, a)
    }
    /// √a
    pub fn sqrt(&mut self, a: Node) -> Node {
        self.unary(UnOp::Sqrt, a)
    }
    /// a²
    pub fn square(&mut self, a: Node) -> Node {
        self.unary(UnOp::Square, a)
    }
    /// a · c for a constant c
    pub fn mul_c(&mut self, a: Node, c: f64) -> Node {
        let c = self.constant(c);
        self.mul(a, c)
    }
    /// a + c for a constant c
    pub fn add_c(&mut self, a: Node, c: f64) -> Node {
        let c = self.constant(c);
        self.add(a, c)
    }
    /// The quadratic smooth union of width `k`:
    /// min(a, b) − max(k − |a − b|, 0)²·(0.25/k), or min(a, b) when k ≤ 0.
    /// The interval evaluator recognises these instructions and bounds
    /// them by the function's exact range ([`crate::interval`]).
    pub fn smooth_union(&mut self, a: Node, b: Node, k: f64) -> Node {
        if k <= 0.0 {
            return self.min(a, b);
        }
        let d = self.sub(a, b);
        let ad = self.abs(d);
        let kc = self.constant(k);
        let kd = self.sub(kc, ad);
        let zero = self.constant(0.0);
        let h = self.max(kd, zero);
        let h2 = self.square(h);
        let corr = self.mul_c(h2, 0.25 / k);
        let m = self.min(a, b);
        self.sub(m, corr)
    }
    /// clamp(a, lo, hi) = min(max(a, lo), hi)
    pub fn clamp(&mut self, a: Node, lo: Node, hi: Node) -> Node {
        let m = self.max(a, lo);
        self.min(m, hi)
    }

    /// The exact partial derivative ∂node/∂x_var (var 0, 1, 2 for x, y, z), as
    /// new DAG nodes (symbolic forward differentiation, shared subexpressions
    /// differentiated once). Non-differentiable points follow the same
    /// conventions as the dual-number evaluator: |x|' = sign(x) (1 at 0),
    /// min/max take the derivative of the selected side (`a` on ties),
    /// floor/round/sign have 0, √x has 0 at 0 and atan2 at the origin. (At a
    /// NaN operand of min/max, which a select cannot detect, this takes `a`'s
    /// derivative and the dual numbers that of the operand min/max returns.)
    pub fn derivative(&mut self, node: Node, var: usize) -> Node {
        let mut memo: HashMap<Node, Node> = HashMap::new();
        self.diff(node, var, &mut memo)
    }

    fn diff(&mut self, n: Node, var: usize, memo: &mut HashMap<Node, Node>) -> Node {
        if let Some(&d) = memo.get(&n) {
            return d;
        }
        let zero = self.constant(0.0);
        let one = self.constant(1.0);
        let d = match self.op(n) {
            Op::Const(_) | Op::Input(_) => zero,
            Op::X => {
                if var == 0 {
                    one
                } else {
                    zero
                }
            }
            Op::Y => {
                if var == 1 {
                    one
                } else {
                    zero
                }
            }
            Op::Z => {
                if var == 2 {
                    one
                } else {
                    zero
                }
            }
            Op::Unary(op, a) => {
                let da = self.diff(a, var, memo);
                if self.const_value(da) == Some(0.0) {
                    zero
                } else {
                    let k = match op {
                        UnOp::Neg => self.constant(-1.0),
                        UnOp::Abs => {
                            let (m1, p1) = (self.constant(-1.0), one);
                            let na = self.neg(a);
                            self.select(na, m1, p1)
                        }
                        UnOp::Sqrt => {
                            let half = self.constant(0.5);
                            let sq = self.sqrt(a);
                            let r = self.div(half, sq);
                            // 0 where sqrt(a) = 0, as the dual evaluator does.
                            self.select(sq, r, zero)
                        }
                        UnOp::Square => self.mul_c(a, 2.0),
                        UnOp::Sin => self.unary(UnOp::Cos, a),
                        UnOp::Cos => {
                            let s = self.unary(UnOp::Sin, a);
                            self.neg(s)
                        }
                        UnOp::Tan => {
                            let t = self.unary(UnOp::Tan, a);
                            let t2 = self.square(t);
                            self.add(one, t2)
                        }
                        UnOp::Asin | UnOp::Acos => {
                            let a2 = self.square(a);
                            let q = self.sub(one, a2);
                            let r = self.sqrt(q);
                            let inv = self.div(one, r);
                            if op == UnOp::Asin {
                                inv
                            } else {
                                self.neg(inv)
                            }
                        }
                        UnOp::Atan => {
                            let a2 = self.square(a);
                            let q = self.add(one, a2);
                            self.div(one, q)
                        }
                        UnOp::Exp => self.unary(UnOp::Exp, a),
                        UnOp::Ln => self.div(one, a),
                        UnOp::Floor | UnOp::Round | UnOp::Sign => zero,
                    };
                    self.mul(k, da)
                }
            }
            Op::Binary(op, a, b) => {
                let (da, db) = (self.diff(a, var, memo), self.diff(b, var, memo));
                match op {
                    BinOp::Add => self.add(da, db),
                    BinOp::Sub => self.sub(da, db),
                    BinOp::Mul => {
                        let t1 = self.mul(da, b);
                        let t2 = self.mul(a, db);
                        self.add(t1, t2)
                    }
                    BinOp::Div => {
                        // (da − (a/b)·db) / b: no b² to underflow or overflow.
                        let num = if self.const_value(db) == Some(0.0) {
                            da
                        } else {
                            let t = self.mul(n, db);
                            self.sub(da, t)
                        };
                        self.div(num, b)
                    }
                    BinOp::Min | BinOp::Max => {
                        // The derivative of the chosen side (a on ties, as the dual evaluator).
                        let c = if op == BinOp::Min {
                            self.sub(a, b)
                        } else {
                            self.sub(b, a)
                        };
                        self.select(c, db, da)
                    }
                    BinOp::Pow => {
                        // d(a^b) = b a^(b−1) da + a^b ln(a) db (the second term only where a > 0).
                        let bm1 = self.add_c(b, -1.0);
                        let pw = self.binary(BinOp::Pow, a, bm1);
                        let k1 = self.mul(b, pw);
                        let t1 = self.mul(k1, da);
                        if self.const_value(db) == Some(0.0) {
                            t1
                        } else {
                            let ab = self.binary(BinOp::Pow, a, b);
                            let la = self.unary(UnOp::Ln, a);
                            let k2 = self.mul(ab, la);
                            let t2 = self.mul(k2, db);
                            let t2 = self.select(a, t2, zero);
                            self.add(t1, t2)
                        }
                    }
                    BinOp::Atan2 => {
                        // d atan2(a, b) = (b da − a db) / (a² + b²)
                        let t1 = self.mul(b, da);
                        let t2 = self.mul(a, db);
                        let num = self.sub(t1, t2);
                        let a2 = self.square(a);
                        let b2 = self.square(b);
                        let den = self.add(a2, b2);
                        let q = self.div(num, den);
                        // 0 where a² + b² = 0, as the dual evaluator does.
                        self.select(den, q, zero)
                    }
                }
            }
            Op::Select(c, a, b) => {
                let (da, db) = (self.diff(a, var, memo), self.diff(b, var, memo));
                self.select(c, da, db)
            }
        };
        memo.insert(n, d);
        d
    }

    /// Copies the nodes that `root` of `from` depends on into this builder
    /// and returns the copy of `root`. Inputs are renumbered by `input`
    /// (for graphs compiled apart with placeholder inputs); lazy selects
    /// stay lazy. The nodes were simplified when `from` built them, so the
    /// copy is the graph this builder would have built from the same calls:
    /// a graph compiled once and imported gives the tape compiling it here
    /// would give.
    pub fn import(&mut self, from: &Builder, root: Node, input: impl Fn(u32) -> u32) -> Node {
        // The nodes root reaches, in index order (a topological order).
        let mut reach = vec![false; root.0 as usize + 1];
        reach[root.0 as usize] = true;
        for i in (0..=root.0 as usize).rev() {
            if !reach[i] {
                continue;
            }
            match from.ops[i] {
                Op::Unary(_, a) => reach[a.0 as usize] = true,
                Op::Binary(_, a, b) => {
                    reach[a.0 as usize] = true;
                    reach[b.0 as usize] = true;
                }
                Op::Select(c, a, b) => {
                    reach[c.0 as usize] = true;
                    reach[a.0 as usize] = true;
                    reach[b.0 as usize] = true;
                }
                Op::Const(_) | Op::X | Op::Y | Op::Z | Op::Input(_) => {}
            }
        }
        let mut map: Vec<Node> = vec![Node(u32::MAX); root.0 as usize + 1];
        for i in 0..=root.0 as usize {
            if !reach[i] {
                continue;
            }
            let m = |n: Node| map[n.0 as usize];
            let op = match from.ops[i] {
                Op::Input(v) => Op::Input(input(v)),
                Op::Unary(o, a) => Op::Unary(o, m(a)),
                Op::Binary(o, a, b) => Op::Binary(o, m(a), m(b)),
                Op::Select(c, a, b) => Op::Select(m(c), m(a), m(b)),
                op @ (Op::Const(_) | Op::X | Op::Y | Op::Z) => op,
            };
            let n = self.intern(op);
            if from.lazy.contains(&Node(i as u32)) {
                self.lazy.insert(n);
            }
            map[i] = n;
        }
        map[root.0 as usize]
    }

    /// Extracts the nodes that `output` depends on as an evaluation tape.
    /// Costs about the number of those nodes, however many others the
    /// builder holds (a scene builds every object's tape from one builder).
    pub fn tape(&self, output: Node) -> Tape {
        let n = output.0 as usize + 1;
        // The nodes `output` needs, found from the highest down (operands
        // precede their users): no array of the builder's size.
        let mut keep: Vec<u32> = Vec::new();
        let mut pending = std::collections::BinaryHeap::from([output.0]);
        while let Some(i) = pending.pop() {
            if keep.last() == Some(&i) {
                continue;
            }
            if keep.len() > n / 8 {
                // Most of the builder: straight from its nodes.
                return self.tape_dense(output);
            }
            keep.push(i);
            let (ops, k) = operand_array(&self.ops[i as usize]);
            pending.extend(ops[..k].iter().map(|m| m.0));
        }
        keep.reverse();
        let rename = |m: Node| Node(keep.binary_search(&m.0).map_or(u32::MAX, |j| j as u32));
        self.tape_of(&keep, rename, output)
    }

    /// [`Builder::tape`] for an output that needs much of the builder:
    /// marks over arrays of its size.
    fn tape_dense(&self, output: Node) -> Tape {
        let n = output.0 as usize + 1;
        let mut needed = vec![false; n];
        needed[n - 1] = true;
        for i in (0..n).rev() {
            if needed[i] {
                let (ops, k) = operand_array(&self.ops[i]);
                for m in &ops[..k] {
                    needed[m.0 as usize] = true;
                }
            }
        }
        let keep: Vec<u32> = (0..n as u32).filter(|&i| needed[i as usize]).collect();
        let mut map = vec![u32::MAX; n];
        for (j, &i) in keep.iter().enumerate() {
            map[i as usize] = j as u32;
        }
        let rename = |m: Node| Node(map.get(m.0 as usize).copied().unwrap_or(u32::MAX));
        self.tape_of(&keep, rename, output)
    }

    /// The tape of the nodes `keep` (ascending: everything `output`
    /// needs), numbered by `rename` (`u32::MAX` for a node not kept).
    fn tape_of(&self, keep: &[u32], rename: impl Fn(Node) -> Node, output: Node) -> Tape {
        if keep.len() == output.0 as usize + 1 {
            return Tape::extract(&self.ops, &self.lazy, output);
        }
        // The needed nodes alone, in their order: the same tape.
        let ops: Vec<Op> = keep.iter().map(|&i| renamed(self.ops[i as usize], &rename)).collect();
        let lazy = (self.lazy.iter())
            .map(|&l| rename(l))
            .filter(|l| l.0 != u32::MAX)
            .collect();
        Tape::extract(&ops, &lazy, rename(output))
    }
}

/// One step of a tape's emission order.
#[derive(Debug, Clone, Copy)]
enum Emit {
    /// The skip that opens the region of the lazy select at this node.
    Skip(usize),
    /// The node's instruction, if it has one.
    Node(usize),
}

/// The operands of an operation, without allocating: the first n of the array.
fn operand_array(op: &Op) -> ([Node; 3], usize) {
    let z = Node(0);
    match *op {
        Op::Unary(_, a) => ([a, z, z], 1),
        Op::Binary(_, a, b) => ([a, b, z], 2),
        Op::Select(c, a, b) => ([c, a, b], 3),
        _ => ([z; 3], 0),
    }
}

/// `op` with its operands renamed by `m`.
fn renamed(op: Op, m: impl Fn(Node) -> Node) -> Op {
    match op {
        Op::Unary(o, a) => Op::Unary(o, m(a)),
        Op::Binary(o, a, b) => Op::Binary(o, m(a), m(b)),
        Op::Select(c, a, b) => Op::Select(m(c), m(a), m(b)),
        other => other,
    }
}

/// Appends to `order` the nodes of `scope` (sorted node indices) that `top`
/// needs, operands first. A lazy select that the scope always computes
/// opens a region, behind a skip, of the nodes only its `b` operand needs;
/// the region is emitted the same way, so a lazy select inside it opens a
/// region of its own (a tree of bounding volumes skips whole subtrees). A
/// node two regions need is computed outside both, with what it uses.
fn emit_scope(ops: &[Op], is_lazy: &dyn Fn(usize) -> bool, scope: &[usize], top: usize, order: &mut Vec<Emit>) {
    const OUTSIDE: usize = usize::MAX;
    const SHARED: usize = usize::MAX - 1;
    if !scope.iter().any(|&i| is_lazy(i)) {
        // No region to open: the scope's nodes in order (each is needed by
        // `top`, through nodes of the scope).
        order.extend(scope.iter().map(|&i| Emit::Node(i)));
        return;
    }
    let pos = |m: Node| scope.binary_search(&(m.0 as usize)).ok();
    let k = scope.len();
    // Nodes the scope computes always: reached from `top` without going
    // through the `b` of a lazy select.
    let mut eager = vec![false; k];
    if let Ok(t) = scope.binary_search(&top) {
        eager[t] = true;
    }
    for j in (0..k).rev() {
        if !eager[j] {
            continue;
        }
        let i = scope[j];
        let (operands, n) = operand_array(&ops[i]);
        for (slot, &m) in operands[..n].iter().enumerate() {
            if is_lazy(i) && slot == 2 {
                continue;
            }
            if let Some(q) = pos(m) {
                eager[q] = true;
            }
        }
    }
    // Each always-computed lazy select's region: what its `b` reaches that
    // is not computed always. A node reached from two regions is shared.
    let roots: Vec<usize> = (0..k).filter(|&j| eager[j] && is_lazy(scope[j])).collect();
    let mut region = vec![OUTSIDE; k];
    for &rj in &roots {
        let Op::Select(_, _, b) = ops[scope[rj]] else { continue };
        let mut stack = vec![b];
        let mut seen = std::collections::HashSet::new();
        while let Some(m) = stack.pop() {
            let Some(q) = pos(m) else { continue };
            if eager[q] || !seen.insert(q) {
                continue;
            }
            region[q] = if region[q] == OUTSIDE { rj } else { SHARED };
            let (operands, n) = operand_array(&ops[scope[q]]);
            stack.extend_from_slice(&operands[..n]);
        }
    }
    // A shared node is computed always; everything below it that is not
    // was reached from both regions too, so it is shared as well.
    let mut members: HashMap<usize, Vec<usize>> = HashMap::new();
    for j in 0..k {
        match region[j] {
            OUTSIDE => {}
            SHARED => eager[j] = true,
            r => members.entry(r).or_default().push(scope[j]),
        }
    }
    for j in 0..k {
        if !eager[j] {
            continue;
        }
        let i = scope[j];
        if let (Some(inner), Op::Select(_, _, b)) = (members.get(&j), ops[i]) {
            order.push(Emit::Skip(i));
            emit_scope(ops, is_lazy, inner, b.0 as usize, order);
        }
        order.push(Emit::Node(i));
    }
}

/// A tape instruction: an operation writing `out` from slots.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Instr {
    /// `out = op(a)`
    Unary {
        /// the operation
        op: UnOp,
        /// destination slot
        out: u32,
        /// operand slot
        a: u32,
    },
    /// `out = op(a, b)`
    Binary {
        /// the operation
        op: BinOp,
        /// destination slot
        out: u32,
        /// left operand slot
        a: u32,
        /// right operand slot
        b: u32,
    },
    /// `out = if c > 0 { a } else { b }`
    Select {
        /// destination slot
        out: u32,
        /// condition slot
        c: u32,
        /// slot taken when c > 0
        a: u32,
        /// slot taken otherwise
        b: u32,
    },
    /// Skip the next `len` instructions when `c > 0` at every point being
    /// evaluated. They compute the `b` operand of the lazy select that
    /// follows them, which then takes `a` everywhere; nothing else reads
    /// their slots. Evaluators may also ignore it and run them.
    Skip {
        /// condition slot
        c: u32,
        /// instructions to skip
        len: u32,
    },
}

/// The part of a tape that depends only on inputs: run once per set of
/// input values, in f64, before the points are evaluated.
///
/// A parameter or the time is the same at every point, so everything
/// computed from inputs and constants alone is computed here, exactly as
/// [`Builder`] would have folded it had the inputs been constants; the
/// results then sit in slots of the main tape like constants. A tape that
/// reads no input has an empty prologue.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Prologue {
    /// Scratch slots the prologue needs.
    slots: u32,
    /// Constants in scratch slots.
    constants: Vec<(u32, f64)>,
    /// Inputs: (scratch slot, input index).
    inputs: Vec<(u32, u32)>,
    /// Instructions over the scratch slots (no [`Instr::Skip`]).
    instrs: Vec<Instr>,
    /// (scratch slot, main tape slot) for every value the main tape reads.
    outputs: Vec<(u32, u32)>,
}

impl Prologue {
    /// True when the tape reads no input.
    pub fn is_empty(&self) -> bool {
        self.inputs.is_empty()
    }

    /// Runs the prologue for `vars` into `scratch` (resized as needed) and
    /// returns (main slot, value) for every value the main tape reads. An
    /// input index beyond `vars` reads as NaN.
    pub fn run<'s>(&'s self, vars: &[f64], scratch: &'s mut Vec<f64>) -> impl Iterator<Item = (usize, f64)> + 's {
        scratch.clear();
        scratch.resize(self.slots as usize, 0.0);
        for &(k, v) in &self.constants {
            scratch[k as usize] = v;
        }
        for &(k, v) in &self.inputs {
            scratch[k as usize] = vars.get(v as usize).copied().unwrap_or(f64::NAN);
        }
        for ins in &self.instrs {
            match *ins {
                Instr::Unary { op, out, a } => scratch[out as usize] = apply_unary(op, scratch[a as usize]),
                Instr::Binary { op, out, a, b } => {
                    scratch[out as usize] = apply_binary(op, scratch[a as usize], scratch[b as usize])
                }
                Instr::Select { out, c, a, b } => {
                    scratch[out as usize] = if scratch[c as usize] > 0.0 {
                        scratch[a as usize]
                    } else {
                        scratch[b as usize]
                    }
                }
                Instr::Skip { .. } => {}
            }
        }
        let scratch: &'s Vec<f64> = scratch;
        self.outputs
            .iter()
            .map(move |&(k, slot)| (slot as usize, scratch[k as usize]))
    }

    /// (scratch slot, input index) of every input read.
    pub fn inputs(&self) -> &[(u32, u32)] {
        &self.inputs
    }
    /// Constants in scratch slots.
    pub fn constants(&self) -> &[(u32, f64)] {
        &self.constants
    }
    /// Instructions over the scratch slots.
    pub fn instrs(&self) -> &[Instr] {
        &self.instrs
    }
    /// Scratch slots needed.
    pub fn slots(&self) -> usize {
        self.slots as usize
    }
    /// (scratch slot, main slot) pairs copied into the main tape.
    pub fn outputs(&self) -> &[(u32, u32)] {
        &self.outputs
    }
}

/// Remembers the input values a prologue last ran with, so evaluators rerun
/// it only when a value changed.
#[derive(Debug, Clone, Default)]
pub(crate) struct InputCache {
    last: Vec<u64>,
    valid: bool,
    pub(crate) scratch: Vec<f64>,
}

impl InputCache {
    /// True (and remembers `vars`) when the tape's inputs differ from the last call's.
    pub(crate) fn changed(&mut self, tape: &Tape, vars: &[f64]) -> bool {
        if tape.prologue().is_empty() {
            return false;
        }
        let bits = |v: u32| vars.get(v as usize).copied().unwrap_or(f64::NAN).to_bits();
        if self.valid
            && self.last.len() == tape.vars().len()
            && tape.vars().iter().zip(&self.last).all(|(&v, &l)| bits(v) == l)
        {
            return false;
        }
        self.last.clear();
        self.last.extend(tape.vars().iter().map(|&v| bits(v)));
        self.valid = true;
        true
    }
}

/// A linear program computing one scalar from (x, y, z) and the inputs.
///
/// Slots 0, 1 and 2 hold x, y and z; constants follow, each in its own slot,
/// then the values the [`Prologue`] computes from the inputs; the remaining
/// slots are reused by the instructions. No instruction writes a slot it
/// reads, so evaluators may borrow inputs and output disjointly.
#[derive(Clone)]
pub struct Tape {
    /// What every rewrite of the tape ([`Tape::with_instrs`]) shares with
    /// it: constants, prologue and inputs, behind one pointer so that a
    /// simplified tape costs only its instructions and an evaluator can
    /// check at once that a variant is its own tape's.
    frame: Arc<Frame>,
    instrs: Vec<Instr>,
    slots: u32,
    output: u32,
    /// Names this list of instructions (see [`Tape::id`]).
    id: u64,
}

// Equality and Debug leave the id out: it names a tape, it is not part of
// what the tape computes.
impl std::fmt::Debug for Tape {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tape")
            .field("frame", &self.frame)
            .field("instrs", &self.instrs)
            .field("slots", &self.slots)
            .field("output", &self.output)
            .finish()
    }
}

impl PartialEq for Tape {
    fn eq(&self, other: &Tape) -> bool {
        self.frame == other.frame
            && self.instrs == other.instrs
            && self.slots == other.slots
            && self.output == other.output
    }
}

/// A number no tape made before has.
fn fresh_id() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// The part of a [`Tape`] its rewrites share.
#[derive(Debug, Clone, PartialEq, Default)]
struct Frame {
    constants: Vec<(u32, f64)>,
    prologue: Prologue,
    vars: Vec<u32>,
}

impl Tape {
    fn extract(ops: &[Op], lazy: &rustc_hash::FxHashSet<Node>, output: Node) -> Tape {
        let n = output.0 as usize + 1;
        let operands = |i: usize| {
            let (o, k) = operand_array(&ops[i]);
            o.into_iter().take(k)
        };
        // Uniform nodes depend on no coordinate: the prologue computes them.
        let mut uniform = vec![false; n];
        for i in 0..n {
            uniform[i] = match ops[i] {
                Op::Const(_) | Op::Input(_) => true,
                Op::X | Op::Y | Op::Z => false,
                _ => operands(i).all(|m| uniform[m.0 as usize]),
            };
        }
        // Which nodes the output needs.
        let mut needed = vec![false; n];
        needed[output.0 as usize] = true;
        for i in (0..n).rev() {
            if needed[i] {
                for m in operands(i) {
                    needed[m.0 as usize] = true;
                }
            }
        }
        // The emission order, with lazy regions nested to any depth: a
        // region's own lazy selects get regions inside it (see `emit_scope`).
        let is_lazy = |i: usize| lazy.contains(&Node(i as u32));
        let scope: Vec<usize> = (0..n).filter(|&i| needed[i] && !uniform[i]).collect();
        let mut order: Vec<Emit> = Vec::new();
        emit_scope(ops, &is_lazy, &scope, output.0 as usize, &mut order);
        // Liveness over the emission order.
        let mut last_use = vec![0usize; n];
        for (pos, e) in order.iter().enumerate() {
            let Emit::Node(i) = *e else { continue };
            for m in operands(i) {
                last_use[m.0 as usize] = pos;
            }
        }
        last_use[output.0 as usize] = usize::MAX;

        // A temporary is a per-point operation: it gets a reusable slot.
        let is_temp = |m: usize| !uniform[m] && matches!(ops[m], Op::Unary(..) | Op::Binary(..) | Op::Select(..));
        // Uniform values the per-point part reads (or the output itself).
        let mut read_by_points = vec![false; n];
        read_by_points[output.0 as usize] = true;
        for i in 0..n {
            if needed[i] && !uniform[i] {
                for m in operands(i) {
                    read_by_points[m.0 as usize] = true;
                }
            }
        }

        let mut slot_of = vec![u32::MAX; n];
        let mut constants = Vec::new();
        let mut next_slot = 3u32;
        for i in 0..n {
            if !needed[i] {
                continue;
            }
            match ops[i] {
                Op::X => slot_of[i] = 0,
                Op::Y => slot_of[i] = 1,
                Op::Z => slot_of[i] = 2,
                Op::Const(v) if read_by_points[i] => {
                    slot_of[i] = next_slot;
                    constants.push((next_slot, v));
                    next_slot += 1;
                }
                _ => {}
            }
        }
        // The prologue: every needed uniform node but the constants only the
        // per-point part reads gets a scratch slot, in index order.
        let mut prologue = Prologue::default();
        let mut scratch_of = vec![u32::MAX; n];
        let feeds_prologue = {
            let mut f = vec![false; n];
            for i in 0..n {
                if needed[i] && uniform[i] && !matches!(ops[i], Op::Const(_)) {
                    f[i] = true;
                }
            }
            f
        };
        let mut read_by_prologue = vec![false; n];
        for j in (0..n).filter(|&j| feeds_prologue[j]) {
            for m in operands(j) {
                read_by_prologue[m.0 as usize] = true;
            }
        }
        let mut vars = Vec::new();
        for i in 0..n {
            if !needed[i] || !uniform[i] {
                continue;
            }
            if !feeds_prologue[i] && !read_by_prologue[i] {
                continue;
            }
            let k = prologue.slots;
            prologue.slots += 1;
            scratch_of[i] = k;
            let s = |m: Node| scratch_of[m.0 as usize];
            match ops[i] {
                Op::Const(v) => prologue.constants.push((k, v)),
                Op::Input(v) => {
                    prologue.inputs.push((k, v));
                    vars.push(v);
                }
                Op::Unary(op, a) => prologue.instrs.push(Instr::Unary { op, out: k, a: s(a) }),
                Op::Binary(op, a, b) => prologue.instrs.push(Instr::Binary {
                    op,
                    out: k,
                    a: s(a),
                    b: s(b),
                }),
                Op::Select(c, a, b) => prologue.instrs.push(Instr::Select {
                    out: k,
                    c: s(c),
                    a: s(a),
                    b: s(b),
                }),
                Op::X | Op::Y | Op::Z => unreachable!("coordinates are not uniform"),
            }
            if feeds_prologue[i] && read_by_points[i] {
                slot_of[i] = next_slot;
                prologue.outputs.push((k, next_slot));
                next_slot += 1;
            }
        }
        vars.sort_unstable();
        vars.dedup();

        let mut free: Vec<u32> = Vec::new();
        let mut instrs = Vec::new();
        let mut pending: Vec<(usize, usize)> = Vec::new(); // (instr index of a skip, region root)
        for (pos, e) in order.iter().enumerate() {
            let i = match *e {
                Emit::Skip(root) => {
                    let Op::Select(c, _, _) = ops[root] else { unreachable!() };
                    pending.push((instrs.len(), root));
                    instrs.push(Instr::Skip {
                        c: slot_of[c.0 as usize],
                        len: 0,
                    });
                    continue;
                }
                Emit::Node(i) => i,
            };
            if !is_temp(i) {
                continue;
            }
            if let Some(k) = pending.iter().position(|&(_, root)| root == i) {
                // The region ends here: patch its skip length.
                let (at, _) = pending.remove(k);
                let len = (instrs.len() - at - 1) as u32;
                if let Instr::Skip { len: l, .. } = &mut instrs[at] {
                    *l = len;
                }
            }
            let out = free.pop().unwrap_or_else(|| {
                next_slot += 1;
                next_slot - 1
            });
            slot_of[i] = out;
            let s = |m: Node| slot_of[m.0 as usize];
            let instr = match ops[i] {
                Op::Unary(op, a) => Instr::Unary { op, out, a: s(a) },
                Op::Binary(op, a, b) => Instr::Binary {
                    op,
                    out,
                    a: s(a),
                    b: s(b),
                },
                Op::Select(c, a, b) => Instr::Select {
                    out,
                    c: s(c),
                    a: s(a),
                    b: s(b),
                },
                _ => unreachable!(),
            };
            instrs.push(instr);
            // Free operands whose last use is this instruction (after choosing `out`,
            // so that no instruction writes a slot it reads).
            let (ops_i, k) = operand_array(&ops[i]);
            for (j, m) in ops_i[..k].iter().enumerate() {
                // Each operand once (an operation may read a node twice).
                if ops_i[..j].contains(m) {
                    continue;
                }
                if last_use[m.0 as usize] == pos && is_temp(m.0 as usize) {
                    free.push(slot_of[m.0 as usize]);
                }
            }
        }
        let output_slot = slot_of[output.0 as usize];
        Tape {
            frame: Arc::new(Frame {
                constants,
                prologue,
                vars,
            }),
            instrs,
            slots: next_slot,
            output: output_slot,
            id: fresh_id(),
        }
    }

    /// Constants and the slots they live in.
    pub fn constants(&self) -> &[(u32, f64)] {
        &self.frame.constants
    }
    /// The part computed from inputs alone, once per set of input values.
    pub fn prologue(&self) -> &Prologue {
        &self.frame.prologue
    }
    /// The inputs the tape reads (sorted indices into the variable slice);
    /// empty for a tape of the coordinates alone.
    pub fn vars(&self) -> &[u32] {
        &self.frame.vars
    }
    /// This tape with its inputs fixed at `vars`: the prologue's values
    /// become constants, so the result reads no input and computes exactly
    /// what this tape computes with `vars`. For consumers that take a
    /// whole shape at one moment (the mesher, exports).
    pub fn bind(&self, vars: &[f64]) -> Tape {
        let mut t = self.clone();
        if self.frame.prologue.is_empty() {
            return t;
        }
        let mut scratch = Vec::new();
        let mut constants = self.frame.constants.clone();
        constants.extend(self.frame.prologue.run(vars, &mut scratch).map(|(k, v)| (k as u32, v)));
        t.frame = Arc::new(Frame {
            constants,
            ..Frame::default()
        });
        t
    }

    /// This tape with other instructions (the same constants, prologue,
    /// inputs, slots and output slot): for rewrites such as
    /// [`crate::simplify::simplify`], which must keep the tape's invariants.
    ///
    /// # Panics
    /// When an instruction names a slot beyond the tape's slots or writes a
    /// slot it reads: evaluators rely on both.
    pub fn with_instrs(&self, instrs: Vec<Instr>) -> Tape {
        for ins in &instrs {
            let (out, reads): (u32, [u32; 3]) = match *ins {
                Instr::Unary { out, a, .. } => (out, [a, a, a]),
                Instr::Binary { out, a, b, .. } => (out, [a, b, b]),
                Instr::Select { out, c, a, b } => (out, [c, a, b]),
                Instr::Skip { c, .. } => (c, [c, c, c]),
            };
            let skip = matches!(ins, Instr::Skip { .. });
            assert!(
                out < self.slots && reads.iter().all(|&r| r < self.slots && (skip || r != out)),
                "instruction {ins:?} breaks the tape's slot invariants"
            );
        }
        Tape {
            frame: Arc::clone(&self.frame),
            instrs,
            slots: self.slots,
            output: self.output,
            id: fresh_id(),
        }
    }

    /// A number that names this tape's instructions: tapes made separately
    /// have different ones, a clone (and [`Tape::bind`]) keeps it. For
    /// evaluators that cache what they learn of a tape's instructions.
    pub fn id(&self) -> u64 {
        self.id
    }

    /// True when `other` is a rewrite of this tape (or the other way
    /// round): the same constants, prologue, inputs and slots, so one
    /// evaluator's storage serves both. Cheap for tapes made by
    /// [`Tape::with_instrs`], which share them.
    pub fn same_frame(&self, other: &Tape) -> bool {
        self.slots == other.slots && (Arc::ptr_eq(&self.frame, &other.frame) || self.frame == other.frame)
    }

    /// True when the tape reads input `var`.
    pub fn reads(&self, var: u32) -> bool {
        self.frame.vars.binary_search(&var).is_ok()
    }
    /// Instructions in evaluation order.
    pub fn instrs(&self) -> &[Instr] {
        &self.instrs
    }
    /// Total slots needed.
    pub fn slots(&self) -> usize {
        self.slots as usize
    }
    /// The slot holding the result.
    pub fn output(&self) -> usize {
        self.output as usize
    }

    /// Number of instructions.
    pub fn len(&self) -> usize {
        self.instrs.len()
    }

    /// True when the per-point part is empty: the result is a constant, a
    /// coordinate or a value of the inputs alone.
    pub fn is_empty(&self) -> bool {
        self.instrs.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A graph built apart and imported gives the tape building it in place
    /// gives, with its inputs renumbered and its lazy selects kept.
    #[test]
    fn import_is_building_in_place() {
        // Something already in the target: shared x, a constant, an input.
        let prefix = |b: &mut Builder| {
            let x = b.x();
            let c = b.constant(0.5);
            let t = b.input(0);
            let xt = b.mul(x, t);
            b.add(xt, c)
        };
        // The object: reads input `k`, with a lazy select.
        let object = |b: &mut Builder, k: u32| {
            let (x, y) = (b.x(), b.y());
            let r = b.input(k);
            let x2 = b.square(x);
            let y2 = b.square(y);
            let d = b.add(x2, y2);
            let d = b.sqrt(d);
            let _garbage = b.unary(UnOp::Sin, d);
            let near = b.sub(d, r);
            let far = b.add_c(near, -1.0);
            let e = b.unary(UnOp::Cos, near);
            let e = b.add(near, e);
            b.lazy_select(far, near, e)
        };
        let mut direct = Builder::new();
        let p = prefix(&mut direct);
        let o = object(&mut direct, 3);
        let out_direct = direct.min(p, o);

        let mut apart = Builder::new();
        let o_apart = object(&mut apart, 1 << 30);
        let mut target = Builder::new();
        let p = prefix(&mut target);
        let o = target.import(&apart, o_apart, |v| if v >= 1 << 30 { v - (1 << 30) + 3 } else { v });
        let out_import = target.min(p, o);

        let (a, b) = (direct.tape(out_direct), target.tape(out_import));
        assert_eq!(a.vars(), b.vars());
        assert!(b.instrs().iter().any(|i| matches!(i, Instr::Skip { .. })));
        let vars = [0.25, 0.0, 0.0, 0.75];
        let mut pa = crate::eval::PointEvaluator::<f64>::new(&a);
        let mut pb = crate::eval::PointEvaluator::<f64>::new(&b);
        for i in 0..50 {
            let q = [i as f64 * 0.13 - 3.0, (i as f64 * 0.7).sin() * 2.0, 0.0];
            assert_eq!(
                pa.eval(&vars, q[0], q[1], q[2]).to_bits(),
                pb.eval(&vars, q[0], q[1], q[2]).to_bits()
            );
        }
        // Imported into an empty builder, the tape is the same tape.
        let mut alone = Builder::new();
        let o_direct = object(&mut alone, 3);
        let mut empty = Builder::new();
        let o_copy = empty.import(&apart, o_apart, |v| if v >= 1 << 30 { v - (1 << 30) + 3 } else { v });
        assert_eq!(alone.tape(o_direct), empty.tape(o_copy));
    }

    /// A lazy select and its eager twin, over a shared subexpression.
    fn lazy_pair() -> (Tape, Tape) {
        let build = |lazy: bool| {
            let mut b = Builder::new();
            let (x, y, z) = (b.x(), b.y(), b.z());
            let x2 = b.square(x);
            let y2 = b.square(y);
            let z2 = b.square(z);
            let r2 = b.add(x2, y2);
            let r2 = b.add(r2, z2);
            let r = b.sqrt(r2);
            let far = b.add_c(r, -2.0);
            let cheap = b.add_c(r, -1.0);
            // An expensive field that also uses r (shared with the cheap branch).
            let sx = b.unary(UnOp::Sin, x);
            let sy = b.unary(UnOp::Cos, y);
            let t = b.mul(sx, sy);
            let t = b.mul_c(t, 0.1);
            let e = b.add(cheap, t);
            let out = if lazy {
                b.lazy_select(far, cheap, e)
            } else {
                b.select(far, cheap, e)
            };
            let out = b.mul_c(out, 2.0); // something after the select
            b.tape(out)
        };
        (build(true), build(false))
    }

    #[test]
    fn lazy_select_skips_its_region_and_changes_nothing() {
        let (lazy, eager) = lazy_pair();
        assert!(lazy
            .instrs()
            .iter()
            .any(|i| matches!(i, Instr::Skip { len, .. } if *len >= 3)));
        assert!(!eager.instrs().iter().any(|i| matches!(i, Instr::Skip { .. })));
        let mut pl = crate::eval::PointEvaluator::<f64>::new(&lazy);
        let mut pe = crate::eval::PointEvaluator::<f64>::new(&eager);
        let mut bl = crate::eval::BatchEvaluator::<f64>::new(&lazy);
        for scale in [0.3, 1.0, 3.0, 10.0] {
            let pts: Vec<[f64; 3]> = (0..150)
                .map(|i| {
                    let a = i as f64 * 0.7;
                    [a.cos() * scale, (0.3 * a).sin() * scale, a.sin() * scale * 0.8]
                })
                .collect();
            let (xs, ys, zs): (Vec<f64>, Vec<f64>, Vec<f64>) = (
                pts.iter().map(|p| p[0]).collect(),
                pts.iter().map(|p| p[1]).collect(),
                pts.iter().map(|p| p[2]).collect(),
            );
            let mut out = vec![0.0; pts.len()];
            bl.eval(&[], &xs, &ys, &zs, &mut out);
            for (k, p) in pts.iter().enumerate() {
                let want = pe.eval(&[], p[0], p[1], p[2]);
                assert_eq!(pl.eval(&[], p[0], p[1], p[2]), want, "point {p:?}");
                assert_eq!(out[k], want, "batch {p:?}");
            }
        }
    }

    /// A tree of bounding spheres: the union of eight small spheres in two
    /// groups of four, each sphere and each group behind a lazy select, so
    /// the tape nests skips; and its eager twin.
    fn nested_pair() -> (Tape, Tape) {
        let build = |lazy: bool| {
            let mut b = Builder::new();
            let (x, y, z) = (b.x(), b.y(), b.z());
            let ball = |b: &mut Builder, c: [f64; 3], r: f64| {
                let dx = b.add_c(x, -c[0]);
                let dy = b.add_c(y, -c[1]);
                let dz = b.add_c(z, -c[2]);
                let (dx, dy, dz) = (b.square(dx), b.square(dy), b.square(dz));
                let s = b.add(dx, dy);
                let s = b.add(s, dz);
                let s = b.sqrt(s);
                b.add_c(s, -r)
            };
            let pick = |b: &mut Builder, far: Node, near: Node, e: Node| {
                if lazy {
                    b.lazy_select(far, near, e)
                } else {
                    b.select(far, near, e)
                }
            };
            let mut groups = Vec::new();
            for g in 0..2 {
                let gc = [4.0 * g as f64 - 2.0, 0.0, 0.0];
                let bound = ball(&mut b, gc, 1.6);
                let mut u = b.constant(f64::INFINITY);
                for k in 0..4 {
                    let a = k as f64 * std::f64::consts::FRAC_PI_2;
                    let c = [gc[0] + a.cos(), a.sin(), 0.0];
                    let d = ball(&mut b, c, 0.3);
                    // Something expensive per sphere, skipped when far.
                    let w = b.unary(UnOp::Sin, d);
                    let w = b.mul_c(w, 1e-3);
                    let d = b.add(d, w);
                    let own = ball(&mut b, c, 0.4);
                    let far = b.add_c(own, -0.1);
                    let one = pick(&mut b, far, own, d);
                    u = b.min(u, one);
                }
                let far = b.add_c(bound, -0.2);
                groups.push(pick(&mut b, far, bound, u));
            }
            let out = b.min(groups[0], groups[1]);
            b.tape(out)
        };
        (build(true), build(false))
    }

    #[test]
    fn lazy_selects_inside_a_region_nest_their_skips() {
        let (lazy, eager) = nested_pair();
        let ins = lazy.instrs();
        // A skip inside another skip's range.
        let skips: Vec<(usize, usize)> = ins
            .iter()
            .enumerate()
            .filter_map(|(k, i)| match i {
                Instr::Skip { len, .. } => Some((k, k + *len as usize)),
                _ => None,
            })
            .collect();
        assert_eq!(skips.len(), 10, "two groups and eight spheres: {skips:?}");
        let nested = skips
            .iter()
            .filter(|&&(a, e)| skips.iter().any(|&(a2, e2)| a2 < a && e <= e2))
            .count();
        assert_eq!(nested, 8, "every sphere's skip sits inside its group's");
        let mut pl = crate::eval::PointEvaluator::<f64>::new(&lazy);
        let mut pe = crate::eval::PointEvaluator::<f64>::new(&eager);
        let mut bl = crate::eval::BatchEvaluator::<f64>::new(&lazy);
        for scale in [0.5, 1.5, 2.5, 6.0] {
            let pts: Vec<[f64; 3]> = (0..200)
                .map(|i| {
                    let a = i as f64 * 0.37;
                    [
                        a.cos() * scale - 2.0 + 0.02 * i as f64,
                        (1.3 * a).sin() * scale,
                        0.1 * a.sin(),
                    ]
                })
                .collect();
            let col = |j: usize| pts.iter().map(|p| p[j]).collect::<Vec<f64>>();
            let mut out = vec![0.0; pts.len()];
            bl.eval(&[], &col(0), &col(1), &col(2), &mut out);
            for (k, p) in pts.iter().enumerate() {
                let want = pe.eval(&[], p[0], p[1], p[2]);
                assert_eq!(pl.eval(&[], p[0], p[1], p[2]), want, "point {p:?}");
                assert_eq!(out[k], want, "batch {p:?}");
            }
        }
        // Far from both groups, a point runs neither group's region.
        let inside: usize = skips
            .iter()
            .filter(|&&(a, _)| !skips.iter().any(|&(a2, e2)| a2 < a && a <= e2))
            .map(|&(a, e)| e - a)
            .sum();
        assert!(inside * 2 > ins.len(), "most of the tape sits in the two group regions");
    }

    #[test]
    fn shares_and_folds() {
        let mut b = Builder::new();
        let x = b.x();
        let two = b.constant(2.0);
        let s1 = b.add(x, two);
        let s2 = b.add(two, x);
        assert_eq!(s1, s2);
        let three = b.constant(3.0);
        let five = b.add(two, three);
        assert_eq!(b.const_value(five), Some(5.0));
        let m = b.mul(s1, s1);
        assert!(matches!(b.op(m), Op::Unary(UnOp::Square, _)));
    }

    #[test]
    fn symbolic_derivatives_match_dual_numbers() {
        use crate::eval::{Dual, PointEvaluator};
        use crate::Library;
        let srcs = [
            "smooth_union(torus(rotate_x(p, 0.7), 1.0, 0.3), box(p - vec3(0.5), vec3(0.4)), 0.2)",
            "octahedron(twist_y(p, 2.0), 1.0) + displace(p, 0.1, 7.0)",
            "pow(abs(p.y) + 0.5, 1.5) * exp(-p.z) + atan(p.x, p.z + 3.0) + tan(p.x * 0.2) - asin(0.1 * p.y) + acos(0.2 * p.z)",
            "max(p.x, p.y) / (2.0 + cos(p.z)) + min(sqrt(p.x * p.x + 1.0), log(p.y * p.y + 2.0))",
        ];
        let lib = Library::new();
        for src in srcs {
            let mut b = Builder::new();
            let f = lib.compile(&mut b, src, 0).unwrap();
            let grads: Vec<Node> = (0..3).map(|v| b.derivative(f, v)).collect();
            let tapes: Vec<Tape> = grads.iter().map(|&g| b.tape(g)).collect();
            let ft = b.tape(f);
            let mut dual = PointEvaluator::<Dual>::new(&ft);
            for k in 0..200 {
                let t = k as f64 * 0.37;
                let p = [t.sin() * 1.7, (t * 1.3).cos() * 1.2, (t * 0.7).sin() * 1.5];
                let d = dual
                    .eval(
                        &[],
                        Dual {
                            v: p[0],
                            d: [1.0, 0.0, 0.0],
                        },
                        Dual {
                            v: p[1],
                            d: [0.0, 1.0, 0.0],
                        },
                        Dual {
                            v: p[2],
                            d: [0.0, 0.0, 1.0],
                        },
                    )
                    .d;
                for v in 0..3 {
                    let s = PointEvaluator::<f64>::new(&tapes[v]).eval(&[], p[0], p[1], p[2]);
                    assert!(
                        (s - d[v]).abs() <= 1e-9 * (1.0 + d[v].abs()),
                        "{src} d/dx{v} at {p:?}: symbolic {s}, dual {}",
                        d[v]
                    );
                }
            }
        }
    }

    #[test]
    fn tape_reuses_slots_and_never_aliases() {
        let mut b = Builder::new();
        let (x, y, z) = (b.x(), b.y(), b.z());
        let mut acc = b.square(x);
        for v in [y, z, x, y, z] {
            let s = b.square(v);
            let t = b.add_c(s, 1.5);
            acc = b.add(acc, t);
            acc = b.sqrt(acc);
        }
        let t = b.tape(acc);
        // Temporaries are reused: far fewer slots than instructions.
        assert!(
            t.slots() < 3 + 1 + t.len() / 2,
            "{} slots for {} instructions",
            t.slots(),
            t.len()
        );
        for i in &t.instrs {
            match *i {
                Instr::Unary { out, a, .. } => assert_ne!(out, a),
                Instr::Binary { out, a, b, .. } => assert!(out != a && out != b),
                Instr::Select { out, c, a, b } => assert!(out != a && out != b && out != c),
                Instr::Skip { .. } => {}
            }
        }
    }

    /// A tape taken from a builder that holds other shapes too (a scene's
    /// objects) is the tape of its shape alone.
    #[test]
    fn tapes_ignore_the_rest_of_the_builder() {
        let blob = |b: &mut Builder, c: f64| {
            let (x, y, z) = (b.x(), b.y(), b.z());
            let dx = b.add_c(x, -c);
            let (sx, sy, sz) = (b.square(dx), b.square(y), b.square(z));
            let s1 = b.add(sx, sy);
            let s = b.add(s1, sz);
            let len = b.sqrt(s);
            let zero = b.constant(0.0);
            let pos = b.max(y, zero);
            let d = b.add_c(len, -0.5);
            b.sub(d, pos)
        };
        let mut many = Builder::new();
        let mut last = blob(&mut many, 0.0);
        for i in 1..50 {
            let n = blob(&mut many, i as f64);
            last = many.smooth_union(last, n, 0.1);
        }
        let alone_node = blob(&mut many, 7.25);
        let mut one = Builder::new();
        let node = blob(&mut one, 7.25);
        let alone = one.tape(node);
        let taken = many.tape(alone_node);
        // The same instructions (shared nodes may come in another order).
        assert_eq!(taken.len(), alone.len());
        let (mut a, mut b) = (
            crate::PointEvaluator::<f64>::new(&taken),
            crate::PointEvaluator::<f64>::new(&alone),
        );
        for p in [[7.0, 0.2, -0.1], [0.0, -1.0, 3.0], [7.5, 0.4, 0.3]] {
            assert_eq!(a.eval(&[], p[0], p[1], p[2]), b.eval(&[], p[0], p[1], p[2]));
        }
        assert!(many.tape(last).len() > 40 * taken.len());
        // A lazy select keeps its skip when taken from among the others.
        let lazy = |b: &mut Builder| {
            let near = blob(b, 3.0);
            let far = b.x();
            let e = b.unary(UnOp::Sin, near);
            b.lazy_select(far, near, e)
        };
        let lazy_node = lazy(&mut many);
        let mut one = Builder::new();
        let node = lazy(&mut one);
        let skips = |t: &Tape| t.instrs().iter().filter(|i| matches!(i, Instr::Skip { .. })).count();
        let (taken, alone) = (many.tape(lazy_node), one.tape(node));
        assert_eq!((taken.len(), skips(&taken)), (alone.len(), 1));
    }

    /// Builds sphere(p - (k, 0, 0), r·2) + sin(t) with k, r inputs, or with
    /// the same values as constants.
    fn moving_sphere(inputs: Option<[f64; 3]>) -> Tape {
        let mut b = Builder::new();
        let (x, y, z) = (b.x(), b.y(), b.z());
        let (t, k, r) = match inputs {
            None => (b.input(TIME), b.input(1), b.input(2)),
            Some([t, k, r]) => (b.constant(t), b.constant(k), b.constant(r)),
        };
        let dx = b.sub(x, k);
        let x2 = b.square(dx);
        let y2 = b.square(y);
        let z2 = b.square(z);
        let s = b.add(x2, y2);
        let s = b.add(s, z2);
        let len = b.sqrt(s);
        let r2 = b.mul_c(r, 2.0);
        let d = b.sub(len, r2);
        let st = b.unary(UnOp::Sin, t);
        let w = b.mul_c(st, 0.25);
        let out = b.add(d, w);
        b.tape(out)
    }

    #[test]
    fn inputs_match_folded_constants_bit_for_bit() {
        let live = moving_sphere(None);
        assert_eq!(live.vars(), &[0, 1, 2]);
        assert!(live.reads(TIME) && !live.reads(3));
        // Everything computed from inputs alone is in the prologue.
        assert_eq!(live.prologue().instrs().len(), 3, "{:?}", live.prologue());
        let mut pe = crate::eval::PointEvaluator::<f64>::new(&live);
        let mut pf = crate::eval::PointEvaluator::<f32>::new(&live);
        let mut be = crate::eval::BatchEvaluator::<f32>::new(&live);
        let pts: Vec<[f64; 3]> = (0..100)
            .map(|i| {
                let a = i as f64 * 0.37;
                [a.sin() * 3.0, a.cos() * 2.0, (a * 0.7).sin()]
            })
            .collect();
        let xs: Vec<f32> = pts.iter().map(|p| p[0] as f32).collect();
        let ys: Vec<f32> = pts.iter().map(|p| p[1] as f32).collect();
        let zs: Vec<f32> = pts.iter().map(|p| p[2] as f32).collect();
        let mut out = vec![0.0f32; pts.len()];
        // Several input values in turn, and back: the prologue reruns each time.
        for vars in [[0.0, 0.5, 1.0], [1.3, -2.0, 0.25], [0.0, 0.5, 1.0], [7.0, 1e-3, 3.0]] {
            let folded = moving_sphere(Some(vars));
            assert!(folded.vars().is_empty() && folded.prologue().is_empty());
            let mut fe = crate::eval::PointEvaluator::<f64>::new(&folded);
            let mut ff = crate::eval::PointEvaluator::<f32>::new(&folded);
            let mut fb = crate::eval::BatchEvaluator::<f32>::new(&folded);
            let mut want32 = vec![0.0f32; pts.len()];
            fb.eval(&[], &xs, &ys, &zs, &mut want32);
            be.eval(&vars, &xs, &ys, &zs, &mut out);
            let bound = live.bind(&vars);
            assert!(bound.vars().is_empty());
            let mut bb = crate::eval::PointEvaluator::<f64>::new(&bound);
            for (k, p) in pts.iter().enumerate() {
                let want = fe.eval(&[], p[0], p[1], p[2]);
                assert_eq!(pe.eval(&vars, p[0], p[1], p[2]).to_bits(), want.to_bits());
                assert_eq!(bb.eval(&[], p[0], p[1], p[2]).to_bits(), want.to_bits());
                let (x, y, z) = (xs[k], ys[k], zs[k]);
                assert_eq!(pf.eval(&vars, x, y, z).to_bits(), ff.eval(&[], x, y, z).to_bits());
                assert_eq!(out[k].to_bits(), want32[k].to_bits(), "batch at {p:?}");
            }
        }
        // A missing input reads as NaN: a visible failure, never a plausible value.
        assert!(pe.eval(&[0.0], 0.0, 0.0, 0.0).is_nan());
    }

    #[test]
    fn uniform_values_and_their_inputs() {
        let mut b = Builder::new();
        let (x, k) = (b.x(), b.input(3));
        let two_k = b.mul_c(k, 2.0);
        let sum = b.add(two_k, x);
        assert!(b.is_uniform(two_k) && !b.is_uniform(sum));
        assert_eq!(b.uniform_value(two_k, &[0.0, 0.0, 0.0, 1.5]), Some(3.0));
        assert_eq!(b.uniform_value(sum, &[0.0; 4]), None);
        assert_eq!(b.inputs_of(sum), vec![3]);
        // The derivative of an input is zero.
        let d = b.derivative(two_k, 0);
        assert_eq!(b.uniform_value(d, &[0.0, 0.0, 0.0, 1.5]), Some(0.0));
    }

    #[test]
    fn a_uniform_lazy_select_and_output_need_no_skip() {
        let mut b = Builder::new();
        let (x, k) = (b.x(), b.input(1));
        let kk = b.mul_c(k, 3.0);
        let sel = b.lazy_select(k, kk, k);
        let t = b.tape(sel);
        assert!(t.is_empty(), "a value of the inputs alone has no per-point part");
        assert_eq!(
            crate::eval::PointEvaluator::<f64>::new(&t).eval(&[0.0, 2.0], 0.0, 0.0, 0.0),
            6.0
        );
        let out = b.add(sel, x);
        let t = b.tape(out);
        assert!(!t.instrs().iter().any(|i| matches!(i, Instr::Skip { .. })));
        assert_eq!(
            crate::eval::PointEvaluator::<f64>::new(&t).eval(&[0.0, -2.0], 1.0, 0.0, 0.0),
            -1.0
        );
    }
}
