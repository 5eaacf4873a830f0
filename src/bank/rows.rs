//! One row of a bank: an instance's parameters and windows, read through the layout or a
//! footer; a folded bank's instance from its stored one ([`super::fold`]).

use super::fold::Fold;
use super::layout::{f32_values, f64_values, u32_values};
use super::reader::{Bank, ShardFile, StoredInstance};
use super::schema::{parquet_err, SensorAxis, PARAMETER_COLUMNS};
use super::BankError;
use arrow_array::{Array, Float32Array, Float64Array, UInt32Array};
use parquet::arrow::arrow_reader::{ParquetRecordBatchReaderBuilder, RowSelection, RowSelector};

impl Bank {
    /// Reads one whole instance (row `instance`: rows are stored in instance order): that row
    /// of its shard file only.
    pub fn read_instance(&self, instance: usize) -> Result<StoredInstance, BankError> {
        let Some(fold) = &self.fold else {
            return self.read_stored_instance(instance);
        };
        if instance >= self.instances() {
            return Err(BankError::NoSuchInstance {
                instance,
                last: self.instances().saturating_sub(1),
            });
        }
        let (i, k) = fold.split(instance, self.stored_instances());
        let stored = self.read_stored_instance(i)?;
        let mut parameters = stored.parameters;
        parameters[3] = self
            .metadata
            .calibration
            .folded_position_m(parameters[3], k);
        Ok(StoredInstance {
            instance: instance as u32,
            parameters,
            forces_kn: fold.windows(&stored.forces_kn, k),
        })
    }

    /// A folded bank's stored instance and whole-bay shift behind instance `v` (`None`: not
    /// folded).
    pub fn fold_split(&self, v: usize) -> Option<(usize, usize)> {
        self.fold
            .as_ref()
            .map(|f| f.split(v, self.stored_instances()))
    }

    /// The axes as stored: a folded bank's sensors, then the sleepers before them
    /// ([`crate::model::Calibration::stored_pads`]); the presented axes otherwise.
    pub fn stored_axes(&self) -> &[SensorAxis] {
        self.fold
            .as_ref()
            .map_or(self.metadata.sensors.as_slice(), Fold::stored_axes)
    }

    /// The presented windows of a folded bank's instance at shift `k` from its stored
    /// instance's windows over [`Bank::stored_axes`] (unchanged when not folded).
    pub fn presented_windows(&self, stored: &[Vec<f32>], k: usize) -> Vec<Vec<f32>> {
        match &self.fold {
            Some(f) => f.windows(stored, k),
            None => stored.to_vec(),
        }
    }

    /// [`Bank::read_instance`] as stored: its row (stored instance number, X_p as stored), its
    /// windows over [`Bank::stored_axes`].
    pub fn read_stored_instance(&self, instance: usize) -> Result<StoredInstance, BankError> {
        let n = self.stored_instances();
        if instance >= n {
            return Err(BankError::NoSuchInstance {
                instance,
                last: n.saturating_sub(1),
            });
        }
        let mut row = instance;
        let shard = self
            .files
            .iter()
            .position(|f| {
                if row < f.rows {
                    true
                } else {
                    row -= f.rows;
                    false
                }
            })
            .expect("the row is within the files' rows");
        let file = &self.files[shard];
        let corrupt = |message: String| BankError::Corrupt {
            path: file.path.clone(),
            message,
        };
        let (number, parameters, samples) = match &self.layout {
            Some(layout) => {
                // Every column's whole chunk is checked (the CRC covers the chunk): 50 MB for a
                // 2,500-row shard of the default bank, a few milliseconds for an audit.
                let at =
                    |col: usize| layout.values(shard, col, row..row + 1, &file.bytes, &file.path);
                let number = u32_values(at(0)?).next().expect("one value");
                let mut parameters = [0.0; PARAMETER_COLUMNS.len()];
                for (k, p) in parameters.iter_mut().enumerate() {
                    *p = f64_values(at(1 + k)?).next().expect("one value");
                }
                let samples: Vec<f32> = (1 + PARAMETER_COLUMNS.len()..layout.widths.len())
                    .map(|col| {
                        let mut v = [0.0f32];
                        f32_values(at(col)?, &mut v);
                        Ok(v[0])
                    })
                    .collect::<Result<_, BankError>>()?;
                (number, parameters, samples)
            }
            None => self.decode_row(file, row)?,
        };
        if number as usize != instance {
            return Err(corrupt(format!(
                "row {row} holds instance {number}, expected {instance}"
            )));
        }
        let mut samples = samples.into_iter();
        let axes = self.stored_axes();
        let forces_kn = axes
            .iter()
            .map(|axis| samples.by_ref().take(axis.samples).collect::<Vec<f32>>())
            .collect::<Vec<_>>();
        if forces_kn
            .iter()
            .zip(axes)
            .any(|(v, a)| v.len() != a.samples)
        {
            return Err(corrupt(format!("row {row} holds too few force samples")));
        }
        Ok(StoredInstance {
            instance: number,
            parameters,
            forces_kn,
        })
    }

    /// One row of a shard through its footer: instance number, parameters, force samples.
    #[allow(clippy::type_complexity)]
    fn decode_row(
        &self,
        file: &ShardFile,
        row: usize,
    ) -> Result<(u32, [f64; PARAMETER_COLUMNS.len()], Vec<f32>), BankError> {
        let corrupt = |message: String| BankError::Corrupt {
            path: file.path.clone(),
            message,
        };
        let reader = ParquetRecordBatchReaderBuilder::new_with_metadata(
            file.bytes.clone(),
            self.footer(file)?.clone(),
        )
        .with_row_selection(RowSelection::from(vec![
            RowSelector::skip(row),
            RowSelector::select(1),
        ]))
        .build()
        .map_err(parquet_err(&file.path))?;
        let mut batches = Vec::new();
        for batch in reader {
            batches.push(batch.map_err(|e| corrupt(e.to_string()))?);
        }
        let batch = match batches.as_slice() {
            [b] if b.num_rows() == 1 => b,
            _ => return Err(corrupt(format!("row {row} could not be read"))),
        };
        let number = batch
            .column(0)
            .as_any()
            .downcast_ref::<UInt32Array>()
            .map(|a| a.value(0))
            .ok_or_else(|| corrupt("the instance column is not u32".into()))?;
        let mut parameters = [0.0; PARAMETER_COLUMNS.len()];
        for (k, p) in parameters.iter_mut().enumerate() {
            *p = batch
                .column(1 + k)
                .as_any()
                .downcast_ref::<Float64Array>()
                .map(|a| a.value(0))
                .ok_or_else(|| corrupt(format!("`{}` is not f64", PARAMETER_COLUMNS[k])))?;
        }
        let samples = (1 + PARAMETER_COLUMNS.len()..batch.num_columns())
            .map(|col| {
                batch
                    .column(col)
                    .as_any()
                    .downcast_ref::<Float32Array>()
                    .map(|a| a.value(0))
                    .ok_or_else(|| corrupt(format!("column {col} is not a force sample")))
            })
            .collect::<Result<Vec<f32>, BankError>>()?;
        Ok((number, parameters, samples))
    }
}
