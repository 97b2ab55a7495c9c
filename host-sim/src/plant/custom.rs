//! `[plant] model = "custom"`: dynamics written as expressions in the scenario file.
//!
//! Each expression is parsed once by `meval` (precedence, number syntax, positions of syntax
//! errors) and its postfix form compiled into a [`Program`] whose variables are slots of a fixed
//! array and whose `[plant.params]` are constants; the RK4 stages then evaluate the programs
//! with a small fixed stack, without name look-ups or allocation.

use std::collections::BTreeMap;

use meval::{
    tokenizer::{Operation, Token},
    Expr, ParseError, RPNError,
};

use super::{Lanes, Plant};
use crate::error::{Error, Result};

/// Largest state order and actuator count of a custom plant.
pub const MAX_ORDER: usize = 4;
/// Slots `x1..xn, u1..um, u, t`.
const SLOTS: usize = 2 * MAX_ORDER + 2;
/// Deepest evaluation stack an expression may need.
const MAX_DEPTH: usize = 32;

/// The functions an expression may call.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Func {
    Sin,
    Cos,
    Tan,
    Exp,
    Ln,
    Sqrt,
    Abs,
    Tanh,
}

const FUNCTIONS: [(&str, Func); 8] = [
    ("sin", Func::Sin),
    ("cos", Func::Cos),
    ("tan", Func::Tan),
    ("exp", Func::Exp),
    ("ln", Func::Ln),
    ("sqrt", Func::Sqrt),
    ("abs", Func::Abs),
    ("tanh", Func::Tanh),
];

impl Func {
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
        }
    }
}

/// Named constants besides `[plant.params]`.
const CONSTANTS: [(&str, f64); 2] = [("pi", std::f64::consts::PI), ("e", std::f64::consts::E)];

/// One step of a compiled expression (postfix).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Op {
    Const(f64),
    Slot(usize),
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    Pow,
    Neg,
    /// `^` with a small whole exponent: repeated multiplication, as a hand-written `f` has it.
    PowI(i32),
    Call(Func),
}

/// One compiled expression: postfix steps whose stack never exceeds [`MAX_DEPTH`].
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
                Op::Call(f) => stack[sp - 1] = f.apply(stack[sp - 1]),
                bin => {
                    sp -= 1;
                    let (l, r) = (stack[sp - 1], stack[sp]);
                    stack[sp - 1] = match bin {
                        Op::Add => l + r,
                        Op::Sub => l - r,
                        Op::Mul => l * r,
                        Op::Div => l / r,
                        Op::Rem => l % r,
                        _ => l.powf(r),
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
                Op::Call(f) => stack[sp - 1] = stack[sp - 1].map(|x| f.apply(x)),
                bin => {
                    sp -= 1;
                    let (l, r) = (stack[sp - 1], stack[sp]);
                    let each = |g: fn(f64, f64) -> f64| std::array::from_fn(|b| g(l[b], r[b]));
                    stack[sp - 1] = match bin {
                        Op::Add => each(|l, r| l + r),
                        Op::Sub => each(|l, r| l - r),
                        Op::Mul => each(|l, r| l * r),
                        Op::Div => each(|l, r| l / r),
                        Op::Rem => each(|l, r| l % r),
                        _ => each(f64::powf),
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
        Ok(Self { n, m, dynamics })
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

/// 1-based column of byte `offset` in `text`.
fn column(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].chars().count() + 1
}

/// Byte offset of the first whole-word occurrence of `name` in `text`.
fn find_name(text: &str, name: &str) -> usize {
    let word = |c: char| c.is_alphanumeric() || c == '_';
    text.match_indices(name)
        .find(|&(i, _)| {
            let before = text[..i].chars().next_back();
            let after = text[i + name.len()..].chars().next();
            !before.is_some_and(word) && !after.is_some_and(word)
        })
        .map_or(0, |(i, _)| i)
}

/// Byte offset of the first unmatched `(` (`open`) or `)` in `text`.
fn unmatched_paren(text: &str, open: bool) -> usize {
    let mut stack = Vec::new();
    for (i, c) in text.char_indices() {
        match c {
            '(' => stack.push(i),
            ')' if stack.pop().is_none() && !open => return i,
            _ => {}
        }
    }
    stack.first().copied().unwrap_or(text.len())
}

/// Byte offset just past the `k`-th token (0-based) of `text`.
fn token_end(text: &str, k: usize) -> usize {
    text.char_indices()
        .map(|(i, c)| i + c.len_utf8())
        .find(|&end| meval::tokenizer::tokenize(&text[..end]).is_ok_and(|t| t.len() > k))
        .unwrap_or(text.len())
}

/// `text` as a [`Program`] over `names`, or why not (with the column).
fn compile(text: &str, names: &BTreeMap<String, Op>) -> std::result::Result<Program, String> {
    let at = |offset: usize| format!("at column {}", column(text, offset));
    // meval's tokenizer panics on input of white space only.
    if text.trim().is_empty() {
        return Err("empty expression".into());
    }
    let expr: Expr = text.parse().map_err(|e| match e {
        meval::Error::ParseError(p) => match p {
            ParseError::UnexpectedToken(i) => format!("syntax error {}: unexpected input", at(i)),
            ParseError::MissingRParen(_) => format!(
                "syntax error {}: this parenthesis is never closed",
                at(unmatched_paren(text, true))
            ),
            ParseError::MissingArgument => format!(
                "syntax error {}: the expression ends where an operand is expected",
                at(text.trim_end().len())
            ),
        },
        meval::Error::RPNError(r) => match r {
            RPNError::MismatchedLParen(_) => format!(
                "syntax error {}: this parenthesis is never closed",
                at(unmatched_paren(text, true))
            ),
            RPNError::MismatchedRParen(_) => format!(
                "syntax error {}: this parenthesis closes nothing",
                at(unmatched_paren(text, false))
            ),
            RPNError::UnexpectedComma(k) | RPNError::NotEnoughOperands(k) => format!(
                "syntax error {}: an operand is missing",
                at(token_end(text, k).saturating_sub(1))
            ),
            RPNError::TooManyOperands => format!("syntax error {}: too many operands", at(0)),
        },
        other => format!("{other}"),
    })?;
    let mut ops = Vec::with_capacity(expr.len());
    let mut depth = 0usize;
    let mut deepest = 0usize;
    for token in expr.iter() {
        let op = match token {
            Token::Number(v) => Op::Const(*v),
            Token::Var(name) => *names.get(name).ok_or_else(|| {
                format!(
                    "unknown variable `{name}` {} (known: x1..xn, u1..um, u, t, pi, e and [plant.params])",
                    at(find_name(text, name))
                )
            })?,
            Token::Binary(o) => match o {
                Operation::Plus => Op::Add,
                Operation::Minus => Op::Sub,
                Operation::Times => Op::Mul,
                Operation::Div => Op::Div,
                Operation::Rem => Op::Rem,
                Operation::Pow => Op::Pow,
            },
            Token::Unary(Operation::Minus) => Op::Neg,
            Token::Unary(_) => continue,
            Token::Func(name, args) => {
                let f = FUNCTIONS
                    .iter()
                    .find(|(f, _)| f == name)
                    .map(|(_, f)| *f)
                    .ok_or_else(|| {
                        format!(
                            "unknown function `{name}` {} (known: sin cos tan exp ln sqrt abs tanh)",
                            at(find_name(text, name))
                        )
                    })?;
                if *args != Some(1) {
                    return Err(format!(
                        "`{name}` {} takes one argument",
                        at(find_name(text, name))
                    ));
                }
                Op::Call(f)
            }
            _ => return Err(format!("syntax error {}", at(0))),
        };
        // Operands an op takes; meval's postfix form is well formed, checked again here so
        // the evaluation stack can never underflow.
        let needs = match op {
            Op::Const(_) | Op::Slot(_) => 0,
            Op::Neg | Op::Call(_) | Op::PowI(_) => 1,
            _ => 2,
        };
        if depth < needs {
            return Err(format!("syntax error {}: an operand is missing", at(0)));
        }
        depth = depth - needs + 1;
        deepest = deepest.max(depth);
        match (ops.last(), op) {
            (Some(&Op::Const(k)), Op::Pow) if k.fract() == 0.0 && (1.0..=16.0).contains(&k) => {
                ops.pop();
                ops.push(Op::PowI(k as i32));
            }
            (Some(&Op::PowI(k)), Op::Mul) => {
                // `c*x^k` as `c*x*x*…*x`, left to right: the order of a hand-written `f`.
                if let Some(&base @ Op::Slot(_)) = ops.iter().rev().nth(1) {
                    ops.pop();
                    ops.push(Op::Mul);
                    for _ in 1..k {
                        ops.push(base);
                        ops.push(Op::Mul);
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
