//! Expressions in one variable `t` as trees: exact derivatives by the rules of differentiation,
//! simplified (constants folded, `0` and `1` terms dropped), evaluated like the compiled
//! programs. Kinks take the mean of the one-sided derivatives: `d/dx abs = sign`,
//! `d/dx sign = 0`, `d/dx sat = 1` inside `(−1, 1)`, `0` outside, `1/2` at `±1`, `d min(a, b)` is
//! `a'` where `a < b`, `b'` where `b < a`, `(a' + b')/2` where equal (and `max` alike).

use super::{parse::Binary, Func};

/// An expression tree in `t`.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    /// A constant.
    Num(f64),
    /// The variable `t`.
    Var,
    /// `−a`.
    Neg(Box<Expr>),
    /// `a op b`.
    Bin(Binary, Box<Expr>, Box<Expr>),
    /// `f(args)`.
    Call(Func, Vec<Expr>),
}

use Expr::{Bin, Call, Neg, Num, Var};

fn b(e: Expr) -> Box<Expr> {
    Box::new(e)
}
fn add(l: Expr, r: Expr) -> Expr {
    Bin(Binary::Add, b(l), b(r))
}
fn sub(l: Expr, r: Expr) -> Expr {
    Bin(Binary::Sub, b(l), b(r))
}
fn mul(l: Expr, r: Expr) -> Expr {
    Bin(Binary::Mul, b(l), b(r))
}
fn div(l: Expr, r: Expr) -> Expr {
    Bin(Binary::Div, b(l), b(r))
}
fn pow(l: Expr, r: Expr) -> Expr {
    Bin(Binary::Pow, b(l), b(r))
}
fn call(f: Func, a: Expr) -> Expr {
    Call(f, vec![a])
}

/// A whole exponent `1..=16` is repeated multiplication, as in the compiled programs.
fn whole_power(k: f64) -> Option<i32> {
    (k.fract() == 0.0 && (1.0..=16.0).contains(&k)).then_some(k as i32)
}

impl Expr {
    /// The value at `t`.
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            Num(v) => *v,
            Var => t,
            Neg(a) => -a.eval(t),
            Bin(op, l, r) => {
                let x = l.eval(t);
                if let (Binary::Pow, Num(k)) = (op, r.as_ref()) {
                    if let Some(k) = whole_power(*k) {
                        return (1..k).fold(x, |acc, _| acc * x);
                    }
                }
                let y = r.eval(t);
                match op {
                    Binary::Add => x + y,
                    Binary::Sub => x - y,
                    Binary::Mul => x * y,
                    Binary::Div => x / y,
                    Binary::Rem => x % y,
                    Binary::Pow => x.powf(y),
                }
            }
            Call(f, args) => match args.as_slice() {
                [a] => f.apply(a.eval(t)),
                [a, c] => f.apply2(a.eval(t), c.eval(t)),
                _ => f64::NAN,
            },
        }
    }

    /// Whether the expression depends on `t`.
    fn has_var(&self) -> bool {
        match self {
            Num(_) => false,
            Var => true,
            Neg(a) => a.has_var(),
            Bin(_, l, r) => l.has_var() || r.has_var(),
            Call(_, args) => args.iter().any(Self::has_var),
        }
    }

    /// `d/dt` of the expression, simplified; `Err` names what has no derivative here.
    pub fn derivative(&self) -> Result<Expr, String> {
        Ok(self.d()?.simplified())
    }

    fn d(&self) -> Result<Expr, String> {
        Ok(match self {
            Num(_) => Num(0.0),
            Var => Num(1.0),
            Neg(a) => Neg(b(a.d()?)),
            Bin(op, l, r) => {
                let (l, r) = (l.as_ref().clone(), r.as_ref().clone());
                let (dl, dr) = (l.d()?, r.d()?);
                match op {
                    Binary::Add => add(dl, dr),
                    Binary::Sub => sub(dl, dr),
                    Binary::Mul => add(mul(dl, r), mul(l, dr)),
                    Binary::Div => sub(div(dl, r.clone()), div(mul(l, dr), mul(r.clone(), r))),
                    Binary::Rem if !r.has_var() => dl,
                    Binary::Rem => {
                        return Err(
                            "`%` with a divisor that depends on t has no derivative here".into(),
                        )
                    }
                    Binary::Pow if !r.has_var() => {
                        mul(mul(r.clone(), pow(l, sub(r, Num(1.0)))), dl)
                    }
                    Binary::Pow => mul(
                        pow(l.clone(), r.clone()),
                        add(mul(dr, call(Func::Ln, l.clone())), div(mul(r, dl), l)),
                    ),
                }
            }
            Call(f, args) => {
                let a = args.first().cloned().unwrap_or(Num(f64::NAN));
                let da = a.d()?;
                let half = |e: Expr| mul(Num(0.5), e);
                match f {
                    Func::Sin => mul(call(Func::Cos, a), da),
                    Func::Cos => Neg(b(mul(call(Func::Sin, a), da))),
                    Func::Tan => mul(add(Num(1.0), pow(call(Func::Tan, a), Num(2.0))), da),
                    Func::Exp => mul(call(Func::Exp, a), da),
                    Func::Ln => div(da, a),
                    Func::Sqrt => div(da, mul(Num(2.0), call(Func::Sqrt, a))),
                    Func::Abs => mul(call(Func::Sign, a), da),
                    Func::Tanh => mul(sub(Num(1.0), pow(call(Func::Tanh, a), Num(2.0))), da),
                    Func::Sign => Num(0.0),
                    Func::Sat => mul(
                        half(add(
                            call(Func::Sign, sub(Num(1.0), a.clone())),
                            call(Func::Sign, add(Num(1.0), a)),
                        )),
                        da,
                    ),
                    Func::Min | Func::Max => {
                        let c = args.get(1).cloned().unwrap_or(Num(f64::NAN));
                        let dc = c.d()?;
                        // sign(c − a) for min, sign(a − c) for max picks the active branch.
                        let pick = if *f == Func::Min {
                            sub(c, a)
                        } else {
                            sub(a, c)
                        };
                        add(
                            half(add(da.clone(), dc.clone())),
                            mul(call(Func::Sign, pick), half(sub(da, dc))),
                        )
                    }
                }
            }
        })
    }

    /// Constants folded, `x + 0`, `x·1`, `x·0`, `x^1`, `x^0`, `−−x` and `0/x` removed.
    pub fn simplified(&self) -> Expr {
        match self {
            Num(_) | Var => self.clone(),
            Neg(a) => match a.simplified() {
                Num(v) => Num(-v),
                Neg(x) => *x,
                x => Neg(b(x)),
            },
            Bin(op, l, r) => {
                let (l, r) = (l.simplified(), r.simplified());
                let zero = |e: &Expr| matches!(e, Num(v) if *v == 0.0);
                let one = |e: &Expr| matches!(e, Num(v) if *v == 1.0);
                if let (Num(_), Num(_)) = (&l, &r) {
                    return Num(Bin(*op, b(l), b(r)).eval(0.0));
                }
                match op {
                    Binary::Add if zero(&l) => r,
                    Binary::Add | Binary::Sub if zero(&r) => l,
                    Binary::Sub if zero(&l) => Neg(b(r)).simplified(),
                    Binary::Mul if zero(&l) || zero(&r) => Num(0.0),
                    Binary::Mul if one(&l) => r,
                    Binary::Mul | Binary::Div if one(&r) => l,
                    Binary::Mul if matches!(l, Num(v) if v == -1.0) => Neg(b(r)).simplified(),
                    Binary::Div if zero(&l) => Num(0.0),
                    Binary::Pow if one(&r) => l,
                    Binary::Pow if zero(&r) => Num(1.0),
                    _ => Bin(*op, b(l), b(r)),
                }
            }
            Call(f, args) => {
                let args: Vec<Expr> = args.iter().map(Self::simplified).collect();
                if args.iter().all(|a| matches!(a, Num(_))) {
                    return Num(Call(*f, args).eval(0.0));
                }
                Call(*f, args)
            }
        }
    }

    /// The expression written out, every operation in parentheses.
    pub fn text(&self) -> String {
        match self {
            Num(v) => format!("{v}"),
            Var => "t".into(),
            Neg(a) => format!("-({})", a.text()),
            Bin(op, l, r) => format!("({} {} {})", l.text(), op.symbol(), r.text()),
            Call(f, args) => {
                let name = super::function_name(*f);
                let a: Vec<String> = args.iter().map(Self::text).collect();
                format!("{name}({})", a.join(", "))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn simplification_drops_neutral_terms_and_folds_constants() {
        let e = add(mul(Num(1.0), Var), mul(Num(0.0), call(Func::Sin, Var)));
        assert_eq!(e.simplified(), Var);
        assert_eq!(pow(Num(2.0), Num(3.0)).simplified(), Num(8.0));
        assert_eq!(Neg(b(Neg(b(Var)))).simplified(), Var);
        assert_eq!(sub(Num(0.0), Var).simplified(), Neg(b(Var)));
    }

    #[test]
    fn kinks_take_the_mean_of_the_one_sided_derivatives() -> Result<(), String> {
        let abs = call(Func::Abs, Var).derivative()?;
        assert_eq!(
            (abs.eval(-2.0), abs.eval(0.0), abs.eval(3.0)),
            (-1.0, 0.0, 1.0)
        );
        let sat = call(Func::Sat, mul(Num(2.0), Var)).derivative()?;
        assert_eq!(
            (sat.eval(0.0), sat.eval(0.5), sat.eval(0.9)),
            (2.0, 1.0, 0.0)
        );
        let min = Call(Func::Min, vec![Var, mul(Num(3.0), Var)]).derivative()?;
        assert_eq!(
            (min.eval(1.0), min.eval(0.0), min.eval(-1.0)),
            (1.0, 2.0, 3.0)
        );
        let max = Call(Func::Max, vec![Var, mul(Num(3.0), Var)]).derivative()?;
        assert_eq!(
            (max.eval(1.0), max.eval(0.0), max.eval(-1.0)),
            (3.0, 2.0, 1.0)
        );
        assert_eq!(call(Func::Sign, Var).derivative()?, Num(0.0));
        Ok(())
    }
}
