//! `[plant] model = "custom"`: dynamics written as expressions in the scenario file.
//!
//! Each expression is parsed once by the grammar in `parse` (precedence, number syntax,
//! positions of syntax errors) and its postfix form compiled into a [`Program`] whose variables
//! are slots of a fixed array and whose `[plant.params]` are constants; the RK4 stages then
//! evaluate the programs with a small fixed stack, without name look-ups or allocation.

mod parse;
mod symbolic;

use std::collections::BTreeMap;

use self::parse::{Binary, Token};
use super::{Lanes, Plant};
use consensus_plot::error::{Error, Result};

/// Largest state order and actuator count of a custom plant.
pub const MAX_ORDER: usize = 4;
/// Slots `x1..xn, u1..um, u, t`.
const SLOTS: usize = 2 * MAX_ORDER + 2;
/// Deepest evaluation stack an expression may need.
const MAX_DEPTH: usize = 32;

/// The functions an expression may call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Func {
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Tanh,
    /// `−1`, `0`, `1` by the sign of the argument.
    Sign,
    /// The argument clamped to `[−1, 1]`.
    Sat,
    /// The smaller of two.
    Min,
    /// The larger of two.
    Max,
}

/// The functions of one argument.
const FUNCTIONS: [(&str, Func); 10] = [
    ("sin", Func::Sin),
    ("cos", Func::Cos),
    ("tan", Func::Tan),
    ("exp", Func::Exp),
    ("ln", Func::Ln),
    ("sqrt", Func::Sqrt),
    ("abs", Func::Abs),
    ("tanh", Func::Tanh),
    ("sign", Func::Sign),
    ("sat", Func::Sat),
];

/// The functions of two arguments.
const FUNCTIONS2: [(&str, Func); 2] = [("min", Func::Min), ("max", Func::Max)];

/// Every function name, for error messages.
const FUNCTION_NAMES: &str = "sin cos tan exp ln sqrt abs tanh sign sat min max";

impl Func {
    /// The function called `name`.
    fn named(name: &str) -> Option<Self> {
        FUNCTIONS
            .iter()
            .chain(&FUNCTIONS2)
            .find(|(f, _)| *f == name)
            .map(|(_, f)| *f)
    }

    /// How many arguments it takes.
    const fn arity(self) -> usize {
        match self {
            Self::Min | Self::Max => 2,
            _ => 1,
        }
    }

    #[inline]
    fn apply(self, x: f64) -> f64 {
        match self {
            Self::Sin => x.sin(),
            Self::Cos => x.cos(),
            Self::Tan => x.tan(),
            Self::Exp => x.exp(),
            Self::Ln => x.ln(),
            Self::Sqrt => x.sqrt(),
            Self::Abs => x.abs(),
            Self::Tanh => x.tanh(),
            Self::Sign => {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    x * 0.0
                }
            }
            Self::Sat => x.clamp(-1.0, 1.0),
            Self::Min | Self::Max => self.apply2(x, x),
        }
    }

    /// A function of two arguments (NaN in, NaN out).
    #[inline]
    fn apply2(self, a: f64, b: f64) -> f64 {
        if a.is_nan() || b.is_nan() {
            return f64::NAN;
        }
        match self {
            Self::Min => a.min(b),
            Self::Max => a.max(b),
            _ => self.apply(a),
        }
    }
}

/// The name of `f` in expressions.
fn function_name(f: Func) -> &'static str {
    FUNCTIONS
        .iter()
        .chain(&FUNCTIONS2)
        .find(|(_, g)| *g == f)
        .map_or("?", |(n, _)| n)
}

/// Named constants besides `[plant.params]`.
const CONSTANTS: [(&str, f64); 2] = [("pi", std::f64::consts::PI), ("e", std::f64::consts::E)];

/// One step of a compiled expression (postfix).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Const(f64),
    Slot(usize),
    Bin(Binary),
    Neg,
    /// `^` with a small whole exponent: repeated multiplication, as a hand-written `f` has it.
    PowI(i32),
    Call(Func),
}

/// One compiled expression: postfix steps whose stack never exceeds `MAX_DEPTH`.
#[derive(Debug, Clone, PartialEq)]
pub struct Program {
    ops: Vec<Op>,
}

impl Program {
    /// The value at slot values `v`.
    #[inline]
    fn eval(&self, v: &[f64; SLOTS]) -> f64 {
        let mut stack = [0.0f64; MAX_DEPTH];
        let mut sp = 0usize;
        for op in &self.ops {
            match *op {
                Op::Const(c) => {
                    stack[sp] = c;
                    sp += 1;
                }
                Op::Slot(k) => {
                    stack[sp] = v[k];
                    sp += 1;
                }
                Op::Neg => stack[sp - 1] = -stack[sp - 1],
                Op::PowI(k) => {
                    let x = stack[sp - 1];
                    let mut r = x;
                    for _ in 1..k {
                        r *= x;
                    }
                    stack[sp - 1] = r;
                }
                Op::Call(f) if f.arity() == 2 => {
                    sp -= 1;
                    stack[sp - 1] = f.apply2(stack[sp - 1], stack[sp]);
                }
                Op::Call(f) => stack[sp - 1] = f.apply(stack[sp - 1]),
                Op::Bin(bin) => {
                    sp -= 1;
                    let (l, r) = (stack[sp - 1], stack[sp]);
                    stack[sp - 1] = match bin {
                        Binary::Add => l + r,
                        Binary::Sub => l - r,
                        Binary::Mul => l * r,
                        Binary::Div => l / r,
                        Binary::Rem => l % r,
                        Binary::Pow => l.powf(r),
                    };
                }
            }
        }
        stack[0]
    }

    /// [`Program::eval`] for `B` agents side by side (`v[slot][b]`): each step once for all
    /// of them, per agent the same operations.
    #[inline]
    fn eval_lanes<const B: usize>(&self, v: &[[f64; B]; SLOTS]) -> [f64; B] {
        let mut stack = [[0.0f64; B]; MAX_DEPTH];
        let mut sp = 0usize;
        for op in &self.ops {
            match *op {
                Op::Const(c) => {
                    stack[sp] = [c; B];
                    sp += 1;
                }
                Op::Slot(k) => {
                    stack[sp] = v[k];
                    sp += 1;
                }
                Op::Neg => stack[sp - 1] = stack[sp - 1].map(|x| -x),
                Op::PowI(k) => {
                    stack[sp - 1] = stack[sp - 1].map(|x| {
                        let mut r = x;
                        for _ in 1..k {
                            r *= x;
                        }
                        r
                    });
                }
                Op::Call(f) if f.arity() == 2 => {
                    sp -= 1;
                    let (l, r) = (stack[sp - 1], stack[sp]);
                    stack[sp - 1] = std::array::from_fn(|b| f.apply2(l[b], r[b]));
                }
                Op::Call(f) => stack[sp - 1] = stack[sp - 1].map(|x| f.apply(x)),
                Op::Bin(bin) => {
                    sp -= 1;
                    let (l, r) = (stack[sp - 1], stack[sp]);
                    let each = |g: fn(f64, f64) -> f64| std::array::from_fn(|b| g(l[b], r[b]));
                    stack[sp - 1] = match bin {
                        Binary::Add => each(|l, r| l + r),
                        Binary::Sub => each(|l, r| l - r),
                        Binary::Mul => each(|l, r| l * r),
                        Binary::Div => each(|l, r| l / r),
                        Binary::Rem => each(|l, r| l % r),
                        Binary::Pow => each(f64::powf),
                    };
                }
            }
        }
        stack[0]
    }
}

/// A user-defined plant `ẋ_j = f_j(x, u_1..u_m, u, t)` (LAW §1 with `f` from the scenario).
#[derive(Debug, Clone, PartialEq)]
pub struct Custom {
    n: usize,
    m: usize,
    dynamics: Vec<Program>,
    /// Units of the output `x_1` and of the inputs (`–` when not named).
    units: (String, String),
}

impl Custom {
    /// Compiles `dynamics` (one expression per state) for `n` states and `m` actuators with
    /// the constants `params`; errors name the key (`plant.dynamics[j]`, 1-based) and the
    /// column.
    pub fn new(
        n: usize,
        m: usize,
        dynamics: &[String],
        params: &BTreeMap<String, f64>,
    ) -> Result<Self> {
        if !(1..=MAX_ORDER).contains(&n) {
            return Err(Error::invalid(
                "plant.n",
                format!("must lie in 1..={MAX_ORDER} (got {n})"),
            ));
        }
        if !(1..=MAX_ORDER).contains(&m) {
            return Err(Error::invalid(
                "plant.m",
                format!("must lie in 1..={MAX_ORDER} (got {m})"),
            ));
        }
        if dynamics.len() != n {
            return Err(Error::invalid(
                "plant.dynamics",
                format!(
                    "expected n = {n} expressions (dx1/dt .. dx{n}/dt), got {}",
                    dynamics.len()
                ),
            ));
        }
        let mut names: BTreeMap<String, Op> = BTreeMap::new();
        for (k, v) in params {
            if !v.is_finite() {
                return Err(Error::invalid(
                    format!("plant.params.{k}"),
                    format!("must be finite (got {v})"),
                ));
            }
            names.insert(k.clone(), Op::Const(*v));
        }
        for j in 0..n {
            names.insert(format!("x{}", j + 1), Op::Slot(j));
        }
        for l in 0..m {
            names.insert(format!("u{}", l + 1), Op::Slot(n + l));
        }
        names.insert("u".into(), Op::Slot(n + m));
        names.insert("t".into(), Op::Slot(n + m + 1));
        for k in params.keys() {
            if names.get(k).is_some_and(|op| matches!(op, Op::Slot(_))) {
                return Err(Error::invalid(
                    format!("plant.params.{k}"),
                    "is the name of a variable (x1..xn, u1..um, u, t)",
                ));
            }
            if FUNCTIONS.iter().any(|(f, _)| f == k) {
                return Err(Error::invalid(
                    format!("plant.params.{k}"),
                    "is the name of a function",
                ));
            }
        }
        for (c, v) in CONSTANTS {
            names.entry(c.into()).or_insert(Op::Const(v));
        }
        let dynamics = dynamics
            .iter()
            .enumerate()
            .map(|(j, text)| {
                compile(text, &names)
                    .map_err(|why| Error::invalid(format!("plant.dynamics[{}]", j + 1), why))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(Self {
            n,
            m,
            dynamics,
            units: ("–".into(), "–".into()),
        })
    }

    /// With `plant.state_units` (one per state) and `plant.input_unit`, shown on the figures'
    /// axes.
    pub fn with_units(self, states: Option<&[String]>, input: Option<&str>) -> Result<Self> {
        let mut units = self.units.clone();
        if let Some(s) = states {
            if s.len() != self.n {
                return Err(Error::invalid(
                    "plant.state_units",
                    format!("expected n = {} units, got {}", self.n, s.len()),
                ));
            }
            units.0 = s[0].clone();
        }
        if let Some(u) = input {
            units.1 = u.into();
        }
        for (key, u) in [
            ("plant.state_units", &units.0),
            ("plant.input_unit", &units.1),
        ] {
            if u.trim().is_empty() || u.chars().count() > 16 {
                return Err(Error::invalid(key, "a unit is 1 to 16 characters"));
            }
        }
        Ok(Self { units, ..self })
    }

    /// Units of the output and of the inputs.
    pub fn units(&self) -> (&str, &str) {
        (&self.units.0, &self.units.1)
    }

    /// State order `n`.
    pub fn n(&self) -> usize {
        self.n
    }

    /// Actuators `m`.
    pub fn m(&self) -> usize {
        self.m
    }
}

impl<const N: usize, const M: usize> Plant<N, M> for Custom {
    /// `t` itself.
    type Time = f64;

    #[inline]
    fn at(&self, t: f64) -> f64 {
        t
    }

    #[inline]
    fn derivative(&self, t: &f64, x: &[f64; N], a: &[f64; M]) -> [f64; N] {
        const {
            assert!(
                N <= MAX_ORDER && M <= MAX_ORDER,
                "custom plants have n, m <= 4"
            )
        };
        let mut v = [0.0; SLOTS];
        v[..N].copy_from_slice(x);
        v[N..N + M].copy_from_slice(a);
        v[N + M] = a.iter().sum();
        v[N + M + 1] = *t;
        let mut dx = [0.0; N];
        for (d, p) in dx.iter_mut().zip(&self.dynamics) {
            *d = p.eval(&v);
        }
        dx
    }

    /// The programs once per step for all `B` agents.
    #[inline]
    fn derivative_lanes<const B: usize>(
        &self,
        t: &f64,
        x: &Lanes<N, B>,
        a: &Lanes<M, B>,
    ) -> Lanes<N, B> {
        let mut v = [[0.0; B]; SLOTS];
        v[..N].copy_from_slice(x);
        v[N..N + M].copy_from_slice(a);
        v[N + M] = std::array::from_fn(|b| a.iter().map(|a| a[b]).sum());
        v[N + M + 1] = [*t; B];
        let mut dx = [[0.0; B]; N];
        for (d, p) in dx.iter_mut().zip(&self.dynamics) {
            *d = p.eval_lanes(&v);
        }
        dx
    }
}

/// A function of time written as an expression in `t` (the leader's `y_d`): its value compiled
/// as the plants' expressions are, and its derivatives `1..=order` as simplified trees
/// (`symbolic`).
#[derive(Debug, Clone, PartialEq)]
pub struct TimeFunction {
    value: Program,
    derivatives: Vec<symbolic::Expr>,
}

/// Slot of `t` in a [`TimeFunction`]'s program.
const T_SLOT: usize = 0;

impl TimeFunction {
    /// `text` in `t` (with `pi`, `e` and every function) and its first `order` derivatives;
    /// `Err` says why not, with the column.
    pub fn new(text: &str, order: usize) -> std::result::Result<Self, String> {
        let mut names: BTreeMap<String, Op> = BTreeMap::new();
        names.insert("t".into(), Op::Slot(T_SLOT));
        for (c, v) in CONSTANTS {
            names.insert(c.into(), Op::Const(v));
        }
        if text.trim().is_empty() {
            return Err("empty expression".into());
        }
        let value = compile_with(text, &names, "t, pi, e")?;
        let mut tree = tree(text).ok_or("not one expression")?;
        let mut derivatives = Vec::with_capacity(order);
        for k in 1..=order {
            tree = tree
                .derivative()
                .map_err(|why| format!("derivative {k}: {why}"))?;
            derivatives.push(tree.clone());
        }
        Ok(Self { value, derivatives })
    }

    /// The value at `t`.
    #[inline]
    pub fn value(&self, t: f64) -> f64 {
        let mut v = [0.0; SLOTS];
        v[T_SLOT] = t;
        self.value.eval(&v)
    }

    /// The `k`-th derivative at `t` (`k = 0`: the value; beyond the order asked for: NaN).
    pub fn derivative(&self, k: usize, t: f64) -> f64 {
        match k {
            0 => self.value(t),
            _ => self.derivatives.get(k - 1).map_or(f64::NAN, |d| d.eval(t)),
        }
    }

    /// The `k`-th derivative (`k ≥ 1`) written out.
    pub fn derivative_text(&self, k: usize) -> Option<String> {
        k.checked_sub(1)
            .and_then(|k| self.derivatives.get(k))
            .map(symbolic::Expr::text)
    }
}

/// The tree of an expression in `t` that [`compile_with`] accepted.
fn tree(text: &str) -> Option<symbolic::Expr> {
    use symbolic::Expr;
    let mut stack: Vec<Expr> = Vec::new();
    for token in parse::postfix(text).ok()? {
        let e = match token {
            Token::Number(v) => Expr::Num(v),
            Token::Name(span) => match text.get(span)? {
                "t" => Expr::Var,
                name => Expr::Num(CONSTANTS.iter().find(|(c, _)| *c == name)?.1),
            },
            Token::Neg => Expr::Neg(Box::new(stack.pop()?)),
            Token::Binary(op) => {
                let r = stack.pop()?;
                Expr::Bin(op, Box::new(stack.pop()?), Box::new(r))
            }
            Token::Call(span, n) => {
                let f = Func::named(text.get(span)?)?;
                let args = stack.split_off(stack.len().checked_sub(n)?);
                Expr::Call(f, args)
            }
        };
        stack.push(e);
    }
    (stack.len() == 1).then(|| stack.pop()).flatten()
}

/// 1-based column (in characters) of byte `offset` in `text`.
fn column(text: &str, offset: usize) -> usize {
    text.char_indices().take_while(|&(i, _)| i < offset).count() + 1
}

/// `text` as a [`Program`] over `names`, or why not (with the column).
fn compile(text: &str, names: &BTreeMap<String, Op>) -> std::result::Result<Program, String> {
    compile_with(
        text,
        names,
        "x1..xn, u1..um, u, t, pi, e and [plant.params]",
    )
}

/// [`compile`] naming `known` variables in its errors.
fn compile_with(
    text: &str,
    names: &BTreeMap<String, Op>,
    known: &str,
) -> std::result::Result<Program, String> {
    let at = |offset: usize| format!("at column {}", column(text, offset));
    if text.trim().is_empty() {
        return Err("empty expression".into());
    }
    let tokens =
        parse::postfix(text).map_err(|e| format!("syntax error {}: {}", at(e.offset), e.why))?;
    let mut ops = Vec::with_capacity(tokens.len());
    let mut depth = 0usize;
    let mut deepest = 0usize;
    for token in tokens {
        let op = match token {
            Token::Number(v) => Op::Const(v),
            Token::Name(span) => {
                let name = text.get(span.clone()).unwrap_or_default();
                *names.get(name).ok_or_else(|| {
                    format!(
                        "unknown variable `{name}` {} (known: {known})",
                        at(span.start)
                    )
                })?
            }
            Token::Binary(b) => Op::Bin(b),
            Token::Neg => Op::Neg,
            Token::Call(span, args) => {
                let name = text.get(span.clone()).unwrap_or_default();
                let f = Func::named(name).ok_or_else(|| {
                    format!(
                        "unknown function `{name}` {} (known: {FUNCTION_NAMES})",
                        at(span.start)
                    )
                })?;
                if args != f.arity() {
                    return Err(format!(
                        "`{name}` {} takes {} argument{} (got {args})",
                        at(span.start),
                        f.arity(),
                        if f.arity() == 1 { "" } else { "s" }
                    ));
                }
                Op::Call(f)
            }
        };
        // Operands an op takes; the parser's postfix form is well formed, checked again here so
        // the evaluation stack can never underflow.
        let needs = match op {
            Op::Const(_) | Op::Slot(_) => 0,
            Op::Call(f) => f.arity(),
            Op::Neg | Op::PowI(_) => 1,
            Op::Bin(_) => 2,
        };
        if depth < needs {
            return Err(format!("syntax error {}: an operand is missing", at(0)));
        }
        depth = depth - needs + 1;
        deepest = deepest.max(depth);
        match (ops.last(), op) {
            (Some(&Op::Const(k)), Op::Bin(Binary::Pow))
                if k.fract() == 0.0 && (1.0..=16.0).contains(&k) =>
            {
                ops.pop();
                ops.push(Op::PowI(k as i32));
            }
            (Some(&Op::PowI(k)), Op::Bin(Binary::Mul)) => {
                // `c*x^k` as `c*x*x*…*x`, left to right: the order of a hand-written `f`.
                if let Some(&base @ Op::Slot(_)) = ops.iter().rev().nth(1) {
                    ops.pop();
                    ops.push(op);
                    for _ in 1..k {
                        ops.push(base);
                        ops.push(op);
                    }
                } else {
                    ops.push(op);
                }
            }
            _ => ops.push(op),
        }
    }
    if deepest > MAX_DEPTH {
        return Err(format!(
            "nested too deeply (needs a stack of {deepest}, at most {MAX_DEPTH})"
        ));
    }
    if depth != 1 {
        return Err(format!("syntax error {}: not one expression", at(0)));
    }
    Ok(Program { ops })
}

#[cfg(test)]
mod tests {
    use rand_chacha::{
        rand_core::{Rng, SeedableRng},
        ChaCha8Rng,
    };

    use super::*;

    fn custom(dynamics: &[&str]) -> Result<Custom> {
        let d: Vec<String> = dynamics.iter().map(|s| s.to_string()).collect();
        let params = BTreeMap::from([("k".to_string(), 0.5)]);
        Custom::new(2, 2, &d, &params)
    }

    fn message(r: Result<Custom>) -> String {
        r.err().map(|e| e.to_string()).unwrap_or_default()
    }

    /// Four agents side by side give each agent's own result to the bit, over every kind of
    /// step (seeded values; the failing case is printed).
    #[test]
    fn lanes_equal_one_agent_at_a_time() -> Result<()> {
        let p = custom(&[
            "x2 + 0.8*x1^3 - k*u % 0.7 + abs(x1)^1.5",
            "-u1 / (1 + x2^2) + sin(t) * tanh(u2) - sqrt(abs(x1)) + exp(-x2^2) + ln(1 + t)",
        ])?;
        let mut draw = crate::plant::tests::Draw(0x2545_f491_4f6c_dd1d);
        for trial in 0..2000 {
            let (x, a) = (draw.lanes::<2>(6.0), draw.lanes::<2>(60.0));
            let t = draw.value(20.0).abs();
            let lanes = <Custom as Plant<2, 2>>::derivative_lanes(&p, &t, &x, &a);
            for b in 0..4 {
                let one = <Custom as Plant<2, 2>>::derivative(
                    &p,
                    &t,
                    &[x[0][b], x[1][b]],
                    &[a[0][b], a[1][b]],
                );
                for j in 0..2 {
                    assert_eq!(
                        lanes[j][b].to_bits(),
                        one[j].to_bits(),
                        "trial {trial}, agent {b}, state {j}: {} vs {} (x = {x:?}, a = {a:?}, t = {t})",
                        lanes[j][b],
                        one[j]
                    );
                }
            }
        }
        Ok(())
    }

    #[test]
    fn evaluates_like_the_formula() -> Result<()> {
        let p = custom(&[
            "x2 + 0.8*x1^3 - k",
            "u - 2*x1^2 + x2^3 + cos(t) + -x1^2 + 2^3^2",
        ])?;
        let (x, a, t) = ([0.3, -1.2], [0.4, 0.7], 1.1f64);
        let dx = <Custom as Plant<2, 2>>::derivative(&p, &t, &x, &a);
        assert_eq!(dx[0], x[1] + 0.8 * x[0] * x[0] * x[0] - 0.5);
        let expect = 1.1 - 2.0 * x[0].powf(2.0) + x[1].powf(3.0) + t.cos() - x[0].powf(2.0) + 512.0;
        assert!((dx[1] - expect).abs() < 1e-12, "{} vs {expect}", dx[1]);
        Ok(())
    }

    /// Example 1's expressions compile to the built-in model's operations in its order:
    /// `0.8*x1^3` as `((0.8·x1)·x1)·x1`, `2*x1^2` as `(2·x1)·x1`, `x2^3` as `x2·x2·x2`.
    #[test]
    fn example1_compiles_to_the_hand_written_order() -> Result<()> {
        use Binary::{Add, Mul, Sub};
        let p = custom(&["x2 + 0.8*x1^3", "u - 2*x1^2 + x2^3 + cos(t)"])?;
        let (x1, x2, u, t) = (Op::Slot(0), Op::Slot(1), Op::Slot(4), Op::Slot(5));
        let (add, mul, sub) = (Op::Bin(Add), Op::Bin(Mul), Op::Bin(Sub));
        let c = Op::Const;
        assert_eq!(
            p.dynamics[0].ops,
            [x2, c(0.8), x1, mul, x1, mul, x1, mul, add]
        );
        assert_eq!(
            p.dynamics[1].ops,
            [
                u,
                c(2.0),
                x1,
                mul,
                x1,
                mul,
                sub,
                x2,
                Op::PowI(3),
                add,
                t,
                Op::Call(Func::Cos),
                add
            ]
        );
        Ok(())
    }

    #[test]
    fn malformed_input_is_an_error_never_a_panic() {
        for text in [
            "",
            " ",
            "(",
            ")",
            "()",
            ",",
            "x1,x2",
            "1+",
            "+",
            "--x1",
            "+x1",
            "sin()",
            "sin(1,2)",
            "sin",
            "x1^x2^",
            "x1 x2",
            "1e999",
            "x1 % 0",
            "((((((((x1))))))))",
            "2(x1)",
            "é",
            "x1)(",
            "max(x1, x2)",
            "u3",
            "t(1)",
        ] {
            if let Ok(p) = custom(&[text, "u"]) {
                let _ = <Custom as Plant<2, 2>>::derivative(&p, &0.5, &[0.1, 0.2], &[0.3, 0.4]);
            }
        }
        let deep = format!("{}x1{}", "(1+".repeat(40), ")".repeat(40));
        let m = message(custom(&[&deep, "u"]));
        assert!(m.contains("nested too deeply"), "{m}");
    }

    /// A generator seeded from `CUSTOM_EXPR_SEED` (fixed in `.cargo/config.toml`, so `cargo test`
    /// runs the same cases everywhere; CI adds a run with a fresh one) or, without it, afresh;
    /// the seed is printed with the command that replays `test`.
    fn seeded(test: &str) -> (u64, ChaCha8Rng) {
        let seed = std::env::var("CUSTOM_EXPR_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .map_or(0, |d| d.as_nanos() as u64)
            });
        eprintln!("{test}: seed {seed} (replay: CUSTOM_EXPR_SEED={seed} cargo test -p host-sim --lib {test})");
        (seed, ChaCha8Rng::seed_from_u64(seed))
    }

    /// A formula of the random test, with the value of each name at the test's point.
    #[derive(Debug)]
    enum Formula {
        Num(f64),
        Name(&'static str, f64),
        Neg(Box<Formula>),
        Bin(char, Box<Formula>, Box<Formula>),
        Call(Func, Box<Formula>),
    }

    impl Formula {
        /// A random formula at most `depth` levels deep; no literal is a whole number, so no
        /// `x^k` becomes a product and the program does the formula's operations in its order.
        fn random(rng: &mut ChaCha8Rng, depth: u32) -> Self {
            const NUMBERS: [f64; 6] = [0.5, 1.5, 2.25, 0.0015, 3.75e-7, 12.125];
            let names = [
                ("x1", 0.1),
                ("x2", 0.2),
                ("u1", 0.3),
                ("u2", 0.4),
                ("u", 0.7),
                ("t", 0.5),
                ("k", 0.5),
                ("pi", std::f64::consts::PI),
                ("e", std::f64::consts::E),
            ];
            let mut pick = |n: usize| (rng.next_u64() % n as u64) as usize;
            let leaf = depth == 0 || pick(4) == 0;
            match (leaf, pick(8)) {
                (true, 0..=2) => Self::Num(NUMBERS[pick(NUMBERS.len())]),
                (true, _) => {
                    let (name, v) = names[pick(names.len())];
                    Self::Name(name, v)
                }
                (false, 0) => Self::Neg(Box::new(Self::random(rng, depth - 1))),
                (false, 1) => {
                    let f = FUNCTIONS[pick(FUNCTIONS.len())].1;
                    Self::Call(f, Box::new(Self::random(rng, depth - 1)))
                }
                (false, _) => {
                    let op = ['+', '-', '*', '/', '%', '^'][pick(6)];
                    let l = Box::new(Self::random(rng, depth - 1));
                    Self::Bin(op, l, Box::new(Self::random(rng, depth - 1)))
                }
            }
        }

        /// Binding strength in the grammar: sum 1, product 2, sign 3, power 4, operand 5.
        fn strength(&self) -> u8 {
            match self {
                Self::Num(_) | Self::Name(..) | Self::Call(..) => 5,
                Self::Neg(_) => 3,
                Self::Bin('^', ..) => 4,
                Self::Bin('+' | '-', ..) => 1,
                Self::Bin(..) => 2,
            }
        }

        /// The formula with the fewest parentheses the grammar needs for it.
        fn text(&self) -> String {
            let wrap = |f: &Self, parens: bool| {
                if parens {
                    format!("({})", f.text())
                } else {
                    f.text()
                }
            };
            match self {
                Self::Num(v) if *v < 0.01 => format!("{v:e}"),
                Self::Num(v) => format!("{v}"),
                Self::Name(name, _) => name.to_string(),
                Self::Neg(a) => format!("-{}", wrap(a, a.strength() < 3)),
                Self::Call(f, a) => {
                    let name = FUNCTIONS
                        .iter()
                        .find(|(_, g)| g == f)
                        .map_or("", |(n, _)| n);
                    format!("{name}({})", a.text())
                }
                Self::Bin('^', l, r) => {
                    format!(
                        "{}^{}",
                        wrap(l, l.strength() < 5),
                        wrap(r, r.strength() < 3)
                    )
                }
                Self::Bin(op, l, r) => {
                    let s = self.strength();
                    let (l, r) = (wrap(l, l.strength() < s), wrap(r, r.strength() <= s));
                    format!("{l} {op} {r}")
                }
            }
        }

        fn value(&self) -> f64 {
            match self {
                Self::Num(v) | Self::Name(_, v) => *v,
                Self::Neg(a) => -a.value(),
                Self::Call(f, a) => f.apply(a.value()),
                Self::Bin(op, l, r) => {
                    let (l, r) = (l.value(), r.value());
                    match op {
                        '+' => l + r,
                        '-' => l - r,
                        '*' => l * r,
                        '/' => l / r,
                        '%' => l % r,
                        _ => l.powf(r),
                    }
                }
            }
        }
    }

    /// Random formulas written with the fewest parentheses compile and evaluate to the bit as
    /// the formula: precedence, associativity and number syntax as documented.
    #[test]
    fn random_formulas_evaluate_as_written() -> Result<()> {
        let (seed, mut rng) = seeded("random_formulas_evaluate_as_written");
        for case in 0..5_000 {
            let f = Formula::random(&mut rng, 6);
            let text = f.text();
            let p = custom(&[&text, "u"])
                .map_err(|e| Error::invalid("seed", format!("{seed}, case {case}: {e}")))?;
            let got = <Custom as Plant<2, 2>>::derivative(&p, &0.5, &[0.1, 0.2], &[0.3, 0.4])[0];
            let want = f.value();
            assert!(
                got.to_bits() == want.to_bits() || (got.is_nan() && want.is_nan()),
                "seed {seed}, case {case}: {text} gave {got}, the formula {want}"
            );
        }
        Ok(())
    }

    /// Random strings of expression pieces and stray characters compile or give an error naming
    /// the key (with a column inside the text), and whatever compiles evaluates: never a panic.
    /// The seed is printed; `CUSTOM_EXPR_SEED=<seed>` replays a run.
    #[test]
    fn random_strings_never_panic() {
        const PIECES: [&str; 36] = [
            "x1", "x2", "u", "u1", "u3", "t", "k", "pi", "e", "sin", "ln", "y1", "(", ")", "(",
            ")", "+", "-", "*", "/", "%", "^", " ", ".", "e", "E", "0", "1", "2", "9", ",", "é",
            "_", "\t", "1.5e-3", "2^",
        ];
        let (seed, mut rng) = seeded("random_strings_never_panic");
        let mut pick = |n: usize| (rng.next_u64() % n as u64) as usize;
        let (mut compiled, mut rejected) = (0, 0);
        for case in 0..20_000 {
            let text: String = (0..pick(24)).map(|_| PIECES[pick(PIECES.len())]).collect();
            let run = std::panic::catch_unwind(|| match custom(&[&text, "u"]) {
                Ok(p) => {
                    let _ = <Custom as Plant<2, 2>>::derivative(&p, &0.5, &[0.1, 0.2], &[0.3, 0.4]);
                    None
                }
                Err(e) => Some(e.to_string()),
            });
            let Ok(error) = run else {
                panic!("seed {seed}, case {case}: {text:?} panicked");
            };
            let Some(m) = error else {
                compiled += 1;
                continue;
            };
            rejected += 1;
            assert!(
                m.contains("plant.dynamics[1]"),
                "seed {seed}: {text:?}: {m}"
            );
            if let Some(col) = m.split("at column ").nth(1) {
                let col: usize = col
                    .split(|c: char| !c.is_ascii_digit())
                    .next()
                    .and_then(|c| c.parse().ok())
                    .unwrap_or(0);
                assert!(
                    (1..=text.chars().count() + 1).contains(&col),
                    "seed {seed}: {text:?}: column outside the text: {m}"
                );
            }
        }
        eprintln!("random expressions: {compiled} compiled, {rejected} rejected");
        assert!(
            compiled > 100 && rejected > 100,
            "{compiled} compiled, {rejected} rejected"
        );
    }

    #[test]
    fn errors_name_the_key_and_the_column() {
        let m = message(custom(&["x2 + 0.8*y1^3", "u"]));
        assert!(
            m.contains("plant.dynamics[1]") && m.contains("`y1` at column 10"),
            "{m}"
        );
        let m = message(custom(&["x2", "u - (x1"]));
        assert!(
            m.contains("plant.dynamics[2]") && m.contains("column 5"),
            "{m}"
        );
        let m = message(custom(&["x2", "u - x1)"]));
        assert!(
            m.contains("plant.dynamics[2]") && m.contains("column 7"),
            "{m}"
        );
        let m = message(custom(&["x2 +", "u"]));
        assert!(
            m.contains("plant.dynamics[1]") && m.contains("column 5"),
            "{m}"
        );
        let m = message(custom(&["x2 + * x1", "u"]));
        assert!(
            m.contains("plant.dynamics[1]") && m.contains("column 6"),
            "{m}"
        );
        let m = message(custom(&["foo(x1)", "u"]));
        assert!(m.contains("unknown function `foo` at column 1"), "{m}");
        let m = message(custom(&["x3", "u"]));
        assert!(m.contains("`x3` at column 1"), "{m}");
        let m = message(custom(&["x1"]));
        assert!(m.contains("plant.dynamics: expected n = 2"), "{m}");
    }
}
