//! `trajectory.parquet` and `results.parquet` (`--format parquet`): the columns and values of
//! the CSV files, typed (`f64` plant side, `f32` controller side; results columns as
//! [`Results`] types them, empty cells null), Snappy-compressed.

use std::{
    fs::File,
    io::{BufWriter, Write},
    path::Path,
    sync::{mpsc::Receiver, Arc},
};

use parquet::{
    basic::{Compression, LogicalType, Repetition, Type as Physical},
    data_type::{BoolType, ByteArray, ByteArrayType, DoubleType, FloatType, Int64Type},
    errors::ParquetError,
    file::{properties::WriterProperties, writer::SerializedFileWriter},
    schema::types::Type,
};

use crate::report::{
    table::{Block, Cells, Field, Layout, Results},
    write_atomic,
};
use consensus_plot::error::{Error, Result};

/// Values buffered before a row group is written (32 MB of `f64` at most).
const ROW_GROUP_VALUES: usize = 1 << 22;

fn io(e: ParquetError) -> std::io::Error {
    std::io::Error::other(e)
}

/// Snappy throughout; dictionary pages only where values repeat (results: names, flags).
/// Trajectory columns are written plain: nearly every sample value is new, so a dictionary
/// costs a hash per value and, once it overflows, a second encoding, and the file grows.
fn properties(dictionary: bool) -> Arc<WriterProperties> {
    Arc::new(
        WriterProperties::builder()
            .set_compression(Compression::SNAPPY)
            .set_dictionary_enabled(dictionary)
            .build(),
    )
}

fn primitive(name: &str, physical: Physical, optional: bool) -> std::io::Result<Arc<Type>> {
    let repetition = if optional {
        Repetition::OPTIONAL
    } else {
        Repetition::REQUIRED
    };
    let mut b = Type::primitive_type_builder(name, physical).with_repetition(repetition);
    if physical == Physical::BYTE_ARRAY {
        b = b.with_logical_type(Some(LogicalType::String));
    }
    b.build().map(Arc::new).map_err(io)
}

fn schema(fields: Vec<Arc<Type>>) -> std::io::Result<Arc<Type>> {
    Type::group_type_builder("schema")
        .with_fields(fields)
        .build()
        .map(Arc::new)
        .map_err(io)
}

/// Buffered values of one trajectory column.
enum Values {
    Wide(usize, Vec<f64>),
    Narrow(usize, Vec<f32>),
}

/// The writer thread of a trajectory: the rows of every block from `rx` into `file`, one row
/// group per [`ROW_GROUP_VALUES`] values.
pub(crate) fn write_trajectory(
    file: File,
    names: &[String],
    layout: Layout,
    rx: &Receiver<Block>,
) -> std::io::Result<()> {
    let fields = layout.fields();
    let types = names
        .iter()
        .zip(&fields)
        .map(|(n, f)| match f {
            Field::Wide(_) => primitive(n, Physical::DOUBLE, false),
            Field::Narrow(_) => primitive(n, Physical::FLOAT, false),
        })
        .collect::<std::io::Result<Vec<_>>>()?;
    let out = BufWriter::with_capacity(1 << 16, file);
    let mut w = SerializedFileWriter::new(out, schema(types)?, properties(false)).map_err(io)?;
    let mut cols: Vec<Values> = fields
        .iter()
        .map(|f| match *f {
            Field::Wide(i) => Values::Wide(i, Vec::new()),
            Field::Narrow(i) => Values::Narrow(i, Vec::new()),
        })
        .collect();
    let group_rows = (ROW_GROUP_VALUES / fields.len().max(1)).max(1);
    let mut rows = 0;
    for block in rx {
        for (wide, narrow) in layout.rows(&block) {
            for c in &mut cols {
                match c {
                    Values::Wide(i, v) => v.push(wide[*i]),
                    Values::Narrow(i, v) => v.push(narrow[*i]),
                }
            }
            rows += 1;
            if rows == group_rows {
                row_group(&mut w, &mut cols)?;
                rows = 0;
            }
        }
    }
    if rows > 0 {
        row_group(&mut w, &mut cols)?;
    }
    w.into_inner().map_err(io)?.flush()
}

/// Writes and clears the buffered values as one row group.
fn row_group<W: Write + Send>(
    w: &mut SerializedFileWriter<W>,
    cols: &mut [Values],
) -> std::io::Result<()> {
    let mut rg = w.next_row_group().map_err(io)?;
    for c in cols.iter_mut() {
        let Some(mut col) = rg.next_column().map_err(io)? else {
            break;
        };
        match c {
            Values::Wide(_, v) => col.typed::<DoubleType>().write_batch(v, None, None),
            Values::Narrow(_, v) => col.typed::<FloatType>().write_batch(v, None, None),
        }
        .map_err(io)?;
        col.close().map_err(io)?;
        match c {
            Values::Wide(_, v) => v.clear(),
            Values::Narrow(_, v) => v.clear(),
        }
    }
    rg.close().map_err(io)?;
    Ok(())
}

/// `results.parquet` in `dir`: the columns of `results.csv` ([`Results`]).
pub fn write_results(dir: &Path, results: &Results) -> Result<()> {
    let path = dir.join("results.parquet");
    let bytes = results_bytes(results).map_err(|e| Error::io(&path, e))?;
    write_atomic(&path, &bytes)
}

fn results_bytes(results: &Results) -> std::io::Result<Vec<u8>> {
    let types = results
        .names
        .iter()
        .zip(&results.columns)
        .map(|(n, c)| {
            let physical = match c {
                Cells::Bool(_) => Physical::BOOLEAN,
                Cells::Int(_) => Physical::INT64,
                Cells::Float(_) => Physical::DOUBLE,
                Cells::Text(_) => Physical::BYTE_ARRAY,
            };
            primitive(n, physical, true)
        })
        .collect::<std::io::Result<Vec<_>>>()?;
    let mut w =
        SerializedFileWriter::new(Vec::new(), schema(types)?, properties(true)).map_err(io)?;
    let mut rg = w.next_row_group().map_err(io)?;
    for column in &results.columns {
        let Some(mut col) = rg.next_column().map_err(io)? else {
            break;
        };
        fn split<T: Clone>(v: &[Option<T>]) -> (Vec<i16>, Vec<T>) {
            let def = v.iter().map(|c| i16::from(c.is_some())).collect();
            (def, v.iter().flatten().cloned().collect())
        }
        match column {
            Cells::Bool(v) => {
                let (def, v) = split(v);
                col.typed::<BoolType>().write_batch(&v, Some(&def), None)
            }
            Cells::Int(v) => {
                let (def, v) = split(v);
                col.typed::<Int64Type>().write_batch(&v, Some(&def), None)
            }
            Cells::Float(v) => {
                let (def, v) = split(v);
                col.typed::<DoubleType>().write_batch(&v, Some(&def), None)
            }
            Cells::Text(v) => {
                let (def, v) = split(v);
                let v: Vec<ByteArray> = v.iter().map(|s| ByteArray::from(s.as_str())).collect();
                col.typed::<ByteArrayType>()
                    .write_batch(&v, Some(&def), None)
            }
        }
        .map_err(io)?;
        col.close().map_err(io)?;
    }
    rg.close().map_err(io)?;
    w.into_inner().map_err(io)
}
