//! The expression grammar of custom plants on `winnow`: text to postfix tokens, or the byte
//! offset and the reason of the first error. Names stay unresolved (`super::compile` does that).
//!
//! ```text
//! sum     = product (("+" | "-") product)*      left-associative
//! product = unary (("*" | "/" | "%") unary)*    left-associative
//! unary   = ("-" | "+") unary | power           a sign binds looser than "^": -x^2 = -(x^2)
//! power   = atom ("^" unary)?                   right-associative: 2^3^2 = 2^9; x^-2 allowed
//! atom    = number | name "(" sum ("," sum)* ")" | name | "(" sum ")"
//! number  = digits ["." digits] [("e" | "E") ["+" | "-"] digits]   (also ".5")
//! name    = (letter | "_") (letter | digit | "_")*                  ASCII
//! ```

use std::ops::Range;

use winnow::{
    ascii::{digit0, digit1, multispace0},
    combinator::{alt, opt},
    error::EmptyError,
    stream::{LocatingSlice, Location},
    token::{one_of, take_while},
    Parser,
};

type Input<'a> = LocatingSlice<&'a str>;

/// Deepest nesting of parentheses, signs and powers the parser follows (its recursion depth).
pub const MAX_NESTING: usize = 64;

/// A binary operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Binary {
    Add,
    Sub,
    Mul,
    Div,
    Rem,
    Pow,
}

impl Binary {
    /// The operator as written.
    pub const fn symbol(self) -> &'static str {
        match self {
            Self::Add => "+",
            Self::Sub => "-",
            Self::Mul => "*",
            Self::Div => "/",
            Self::Rem => "%",
            Self::Pow => "^",
        }
    }
}

/// One step of an expression's postfix form; names are byte ranges of the text.
#[derive(Debug, Clone, PartialEq)]
pub enum Token {
    Number(f64),
    Name(Range<usize>),
    Neg,
    Binary(Binary),
    /// A function applied to the values before it (the count of arguments).
    Call(Range<usize>, usize),
}

/// Where (byte offset) and why a text is not an expression.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SyntaxError {
    pub offset: usize,
    pub why: &'static str,
}

type Parsed = Result<(), SyntaxError>;

/// `text` in postfix order, or its first syntax error.
pub fn postfix(text: &str) -> Result<Vec<Token>, SyntaxError> {
    let mut i = LocatingSlice::new(text);
    let mut p = Postfix(Vec::new());
    p.sum(&mut i, 0)?;
    skip_space(&mut i);
    match next_char(&i) {
        None => Ok(p.0),
        Some(')') => Err(here(&i, "this parenthesis closes nothing")),
        Some(_) => Err(here(&i, "unexpected input (an operator is missing?)")),
    }
}

/// The tokens emitted so far.
struct Postfix(Vec<Token>);

impl Postfix {
    fn sum(&mut self, i: &mut Input<'_>, depth: usize) -> Parsed {
        self.product(i, depth)?;
        while let Some(op) = operator(i, &[('+', Binary::Add), ('-', Binary::Sub)]) {
            self.product(i, depth)?;
            self.0.push(Token::Binary(op));
        }
        Ok(())
    }

    fn product(&mut self, i: &mut Input<'_>, depth: usize) -> Parsed {
        self.unary(i, depth)?;
        let ops = [('*', Binary::Mul), ('/', Binary::Div), ('%', Binary::Rem)];
        while let Some(op) = operator(i, &ops) {
            self.unary(i, depth)?;
            self.0.push(Token::Binary(op));
        }
        Ok(())
    }

    fn unary(&mut self, i: &mut Input<'_>, depth: usize) -> Parsed {
        skip_space(i);
        let start = i.current_token_start();
        match eat(i, one_of(['-', '+'])) {
            Some(sign) => {
                self.unary(i, deeper(depth, start)?)?;
                if sign == '-' {
                    self.0.push(Token::Neg);
                }
                Ok(())
            }
            None => self.power(i, depth),
        }
    }

    fn power(&mut self, i: &mut Input<'_>, depth: usize) -> Parsed {
        self.atom(i, depth)?;
        skip_space(i);
        let start = i.current_token_start();
        if eat(i, '^').is_some() {
            self.unary(i, deeper(depth, start)?)?;
            self.0.push(Token::Binary(Binary::Pow));
        }
        Ok(())
    }

    fn atom(&mut self, i: &mut Input<'_>, depth: usize) -> Parsed {
        skip_space(i);
        let start = i.current_token_start();
        if let Some(lexeme) = eat(i, number) {
            let value =
                lexeme
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite())
                    .ok_or(SyntaxError {
                        offset: start,
                        why: "number out of range",
                    })?;
            self.0.push(Token::Number(value));
            return Ok(());
        }
        if let Some(name) = eat(i, name) {
            skip_space(i);
            let open = i.current_token_start();
            if eat(i, '(').is_some() {
                let args = self.group(i, depth, open, true)?;
                self.0.push(Token::Call(name, args));
            } else {
                self.0.push(Token::Name(name));
            }
            return Ok(());
        }
        if eat(i, '(').is_some() {
            return self.group(i, depth, start, false).map(|_| ());
        }
        Err(match next_char(i) {
            None => here(i, "the expression ends where an operand is expected"),
            Some(')' | ',' | '+' | '-' | '*' | '/' | '%' | '^') => here(i, "an operand is missing"),
            Some(_) => here(i, "expected a number, a name or `(`"),
        })
    }

    /// The rest of a parenthesis opened at byte `open`, a function's arguments (separated by
    /// `,`) if `call`; how many expressions it held.
    fn group(
        &mut self,
        i: &mut Input<'_>,
        depth: usize,
        open: usize,
        call: bool,
    ) -> Result<usize, SyntaxError> {
        let mut args = 1;
        self.sum(i, deeper(depth, open)?)?;
        loop {
            skip_space(i);
            match next_char(i) {
                Some(')') => {
                    let _ = eat(i, ')');
                    return Ok(args);
                }
                None => {
                    return Err(SyntaxError {
                        offset: open,
                        why: "this parenthesis is never closed",
                    })
                }
                Some(',') if call => {
                    let _ = eat(i, ',');
                    self.sum(i, deeper(depth, open)?)?;
                    args += 1;
                }
                Some(_) => return Err(here(i, "expected an operator or `)`")),
            }
        }
    }
}

/// `depth + 1`, or an error at byte `at` beyond [`MAX_NESTING`].
fn deeper(depth: usize, at: usize) -> Result<usize, SyntaxError> {
    if depth < MAX_NESTING {
        Ok(depth + 1)
    } else {
        Err(SyntaxError {
            offset: at,
            why: "nested too deeply (parentheses, signs and powers)",
        })
    }
}

/// The operator of `ops` next in the input, consumed.
fn operator(i: &mut Input<'_>, ops: &[(char, Binary)]) -> Option<Binary> {
    skip_space(i);
    let c = eat(i, one_of(|c: char| ops.iter().any(|&(o, _)| o == c)))?;
    ops.iter().find(|&&(o, _)| o == c).map(|&(_, op)| op)
}

/// The value of `p` if it matches here (consuming it), else `None` with nothing consumed.
fn eat<'a, O>(i: &mut Input<'a>, p: impl Parser<Input<'a>, O, EmptyError>) -> Option<O> {
    opt(p).parse_next(i).ok().flatten()
}

fn skip_space(i: &mut Input<'_>) {
    let _ = eat(i, multispace0);
}

fn next_char(i: &Input<'_>) -> Option<char> {
    i.chars().next()
}

fn here(i: &Input<'_>, why: &'static str) -> SyntaxError {
    SyntaxError {
        offset: i.current_token_start(),
        why,
    }
}

/// A decimal literal, scientific notation allowed.
fn number<'a>(i: &mut Input<'a>) -> Result<&'a str, EmptyError> {
    (
        alt(((digit1, opt(('.', digit0))).void(), ('.', digit1).void())),
        opt((one_of(['e', 'E']), opt(one_of(['+', '-'])), digit1)),
    )
        .take()
        .parse_next(i)
}

/// The byte range of a name.
fn name(i: &mut Input<'_>) -> Result<Range<usize>, EmptyError> {
    (
        one_of(|c: char| c.is_ascii_alphabetic() || c == '_'),
        take_while(0.., |c: char| c.is_ascii_alphanumeric() || c == '_'),
    )
        .span()
        .parse_next(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The postfix form written out: names as text, operators as symbols.
    fn rpn(text: &str) -> String {
        let tokens = postfix(text).unwrap_or_else(|e| panic!("{text}: {e:?}"));
        tokens
            .iter()
            .map(|t| match t {
                Token::Number(v) => format!("{v}"),
                Token::Name(r) => text[r.clone()].to_string(),
                Token::Call(r, n) => format!("{}({n})", &text[r.clone()]),
                Token::Neg => "neg".into(),
                Token::Binary(b) => b.symbol().into(),
            })
            .collect::<Vec<_>>()
            .join(" ")
    }

    #[test]
    fn precedence_associativity_and_numbers() {
        for (text, expect) in [
            ("-x1^2", "x1 2 ^ neg"),
            ("2^3^2", "2 3 2 ^ ^"),
            ("(2^3)^2", "2 3 ^ 2 ^"),
            ("x1*-2", "x1 2 neg *"),
            ("x1^-2", "x1 2 neg ^"),
            ("1.5e-3 + 2.5E+2 + .5 + 3.", "0.0015 250 + 0.5 + 3 +"),
            ("a - b - c", "a b - c -"),
            ("a / b * c % d", "a b / c * d %"),
            ("a + b * c ^ d", "a b c d ^ * +"),
            ("--x1 + +x2", "x1 neg neg x2 +"),
            (" sin ( x1 ) * k\n", "x1 sin(1) k *"),
            ("min(x1, 2 * t)", "x1 2 t * min(2)"),
            ("0.8*x1^3", "0.8 x1 3 ^ *"),
        ] {
            assert_eq!(rpn(text), expect, "{text}");
        }
    }

    #[test]
    fn errors_point_at_the_offending_byte() {
        for (text, offset, why) in [
            ("", 0, "the expression ends where an operand is expected"),
            (
                "x2 +",
                4,
                "the expression ends where an operand is expected",
            ),
            ("x2 + * x1", 5, "an operand is missing"),
            ("u - (x1", 4, "this parenthesis is never closed"),
            ("sin(x1", 3, "this parenthesis is never closed"),
            ("u - x1)", 6, "this parenthesis closes nothing"),
            ("x1 x2", 3, "unexpected input (an operator is missing?)"),
            ("2(x1)", 1, "unexpected input (an operator is missing?)"),
            ("sin(1, 2", 3, "this parenthesis is never closed"),
            ("min(1 2)", 6, "expected an operator or `)`"),
            ("(x1 x2)", 4, "expected an operator or `)`"),
            ("1e999", 0, "number out of range"),
            ("x1 + é", 5, "expected a number, a name or `(`"),
            ("2e", 1, "unexpected input (an operator is missing?)"),
        ] {
            assert_eq!(postfix(text), Err(SyntaxError { offset, why }), "{text:?}");
        }
        let deep = "-".repeat(MAX_NESTING + 1) + "x1";
        assert_eq!(
            postfix(&deep).map_err(|e| (e.offset, e.why)),
            Err((
                MAX_NESTING,
                "nested too deeply (parentheses, signs and powers)"
            ))
        );
        assert!(postfix(&("(".repeat(100_000) + "x1")).is_err());
        assert!(postfix(&"x1^".repeat(100_000)).is_err());
    }
}
