//! Tables in memory: a run's trajectory (the columns of `trajectory.csv`) and a campaign's
//! results (the columns of `results.csv`, typed).

use std::sync::mpsc::Receiver;

use consensus_plot::error::{Error, Result};

/// One column's values.
#[derive(Debug, Clone, PartialEq)]
pub enum Column {
    /// `t`, `yd`, `y`, `x`: the plant side, `f64`.
    F64(Vec<f64>),
    /// `e`, `u`, `q`, estimates: the controller side, `f32`.
    F32(Vec<f32>),
}

impl Column {
    /// Number of rows.
    pub fn len(&self) -> usize {
        match self {
            Self::F64(v) => v.len(),
            Self::F32(v) => v.len(),
        }
    }

    /// No rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The trajectory's columns in the order of `trajectory.csv`'s header.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Table {
    /// Column names (the header).
    pub names: Vec<String>,
    /// One per name.
    pub columns: Vec<Column>,
}

impl Table {
    /// The column named `name`.
    pub fn column(&self, name: &str) -> Option<&Column> {
        let i = self.names.iter().position(|n| n == name)?;
        self.columns.get(i)
    }

    /// Number of rows.
    pub fn rows(&self) -> usize {
        self.columns.first().map_or(0, Column::len)
    }
}

/// The raw values of whole rows, in column order, `f64` and `f32` columns apart.
#[derive(Debug, Default)]
pub(crate) struct Block {
    pub(crate) wide: Vec<f64>,
    pub(crate) narrow: Vec<f32>,
}

/// Column layout: per row `t`, `yd`, then per agent `1 + n` wide (`y`, `x`) and `n + 2m + 3`
/// narrow (`e`, `u`, `q`, estimates) values, then `m` wide (`qf`) per agent.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Layout {
    pub(crate) agents: usize,
    pub(crate) wide: usize,
    pub(crate) narrow: usize,
    pub(crate) m: usize,
}

/// Where a column's values are in a row of a [`Block`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Field {
    /// Index into the row's `f64` values.
    Wide(usize),
    /// Index into the row's `f32` values.
    Narrow(usize),
}

impl Layout {
    /// `f64` values per row.
    pub(crate) fn wide_row(&self) -> usize {
        2 + self.agents * (self.wide + self.m)
    }

    /// `f32` values per row (at least one, so that empty rows still chunk).
    pub(crate) fn narrow_row(&self) -> usize {
        (self.agents * self.narrow).max(1)
    }

    /// The layout of `agents` agents with `n` states and `m` actuators.
    pub(crate) fn new(agents: usize, n: usize, m: usize) -> Self {
        Self {
            agents,
            wide: 1 + n,
            narrow: n + 2 * m + 3,
            m,
        }
    }

    /// Every column in header order: its name in `trajectory.csv` (agents numbered from
    /// `agents`, 0-based, one per agent of the layout) and where its values are in a row.
    pub(crate) fn columns(&self, agents: &[usize]) -> Vec<(String, Field)> {
        let (n, m) = (self.wide - 1, self.m);
        let mut c = vec![("t".into(), Field::Wide(0)), ("yd".into(), Field::Wide(1))];
        for (a, i) in agents.iter().map(|i| i + 1).enumerate() {
            let wide = |j: usize| Field::Wide(2 + a * self.wide + j);
            let narrow = |j: usize| Field::Narrow(a * self.narrow + j);
            c.push((format!("y{i}"), wide(0)));
            c.extend((1..=n).map(|j| (format!("x{i}_{j}"), wide(j))));
            c.extend((1..=n).map(|j| (format!("e{i}_{j}"), narrow(j - 1))));
            c.extend((1..=m).map(|l| (format!("u{i}_{l}"), narrow(n + l - 1))));
            c.extend((1..=m).map(|l| (format!("q{i}_{l}"), narrow(n + m + l - 1))));
            let estimates = ["mu", "xi", "lambda"].into_iter().enumerate();
            c.extend(estimates.map(|(k, e)| (format!("{e}{i}"), narrow(n + 2 * m + k))));
        }
        let qf = 2 + self.agents * self.wide;
        for (a, i) in agents.iter().map(|i| i + 1).enumerate() {
            c.extend((1..=m).map(|l| (format!("qf{i}_{l}"), Field::Wide(qf + a * m + l - 1))));
        }
        c
    }

    /// Every column in header order.
    pub(crate) fn fields(&self) -> Vec<Field> {
        let agents: Vec<usize> = (0..self.agents).collect();
        self.columns(&agents).into_iter().map(|(_, f)| f).collect()
    }

    /// The rows of `block`: their `f64` and `f32` values.
    pub(crate) fn rows<'a>(
        &self,
        block: &'a Block,
    ) -> impl Iterator<Item = (&'a [f64], &'a [f32])> + use<'a> {
        block
            .wide
            .chunks_exact(self.wide_row())
            .zip(block.narrow.chunks_exact(self.narrow_row()))
    }
}

impl Table {
    /// The rows of every block from `rx` as the columns `names` of `layout`.
    pub(crate) fn from_blocks(names: Vec<String>, layout: Layout, rx: &Receiver<Block>) -> Self {
        let fields = layout.fields();
        let mut columns: Vec<Column> = fields
            .iter()
            .map(|f| match f {
                Field::Wide(_) => Column::F64(Vec::new()),
                Field::Narrow(_) => Column::F32(Vec::new()),
            })
            .collect();
        for block in rx {
            for (w, q) in layout.rows(&block) {
                for (c, f) in columns.iter_mut().zip(&fields) {
                    match (c, *f) {
                        (Column::F64(v), Field::Wide(i)) => v.push(w[i]),
                        (Column::F32(v), Field::Narrow(i)) => v.push(q[i]),
                        _ => {}
                    }
                }
            }
        }
        Self { names, columns }
    }
}

/// One column of `results.csv`, typed by its non-empty cells (all `true`/`false`: `Bool`; all
/// integers: `Int`; all numbers: `Float`; else `Text`); an empty cell is `None`.
#[derive(Debug, Clone, PartialEq)]
pub enum Cells {
    /// `diverged`.
    Bool(Vec<Option<bool>>),
    /// `run`, `draw`, integer axes.
    Int(Vec<Option<i64>>),
    /// The metrics, number axes.
    Float(Vec<Option<f64>>),
    /// `status`, `error`, other axes.
    Text(Vec<Option<String>>),
}

impl Cells {
    fn of(cells: &[&str]) -> Self {
        let given = || cells.iter().filter(|c| !c.is_empty());
        let each = |f: &dyn Fn(&str) -> bool| given().next().is_some() && given().all(|c| f(c));
        fn typed<T>(cells: &[&str], f: impl Fn(&str) -> Option<T>) -> Vec<Option<T>> {
            cells.iter().map(|c| f(c)).collect()
        }
        if each(&|c| c == "true" || c == "false") {
            Self::Bool(typed(cells, |c| c.parse().ok()))
        } else if each(&|c| c.parse::<i64>().is_ok()) {
            Self::Int(typed(cells, |c| c.parse().ok()))
        } else if each(&|c| c.parse::<f64>().is_ok()) {
            Self::Float(typed(cells, |c| c.parse().ok()))
        } else {
            Self::Text(typed(cells, |c| (!c.is_empty()).then(|| c.to_string())))
        }
    }
}

/// A campaign's `results.csv` as typed columns.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Results {
    /// The header.
    pub names: Vec<String>,
    /// One per name.
    pub columns: Vec<Cells>,
}

impl Results {
    /// The columns of `header` from the CSV rows `lines` (without their newlines).
    pub fn from_csv<'a>(
        header: &[String],
        lines: impl Iterator<Item = &'a String>,
    ) -> Result<Self> {
        let mut text = String::new();
        for l in lines {
            text.push_str(l);
            text.push('\n');
        }
        let mut records = Vec::new();
        for r in csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .from_reader(text.as_bytes())
            .records()
        {
            records.push(r.map_err(|e| Error::Io(format!("results.csv: {e}")))?);
        }
        let columns = (0..header.len())
            .map(|c| {
                let cells: Vec<&str> = records.iter().map(|r| r.get(c).unwrap_or("")).collect();
                Cells::of(&cells)
            })
            .collect();
        Ok(Self {
            names: header.to_vec(),
            columns,
        })
    }
}
