//! The instances of one shard file, simulated in lockstep batches.
//!
//! A shard holds consecutive instances, of about the same flat length (the population's
//! first coordinate, and so about the same fine-zone length); sorted by their flat's first
//! strike ([`batch_key`]), they are simulated [`LANES`] at a time ([`crate::model::batch`])
//! on the rayon pool and returned in instance order. A lane's result does not depend on its batch-mates,
//! so the rows (and the bank's bytes) are the same for every thread count and batch size.

use super::observer::GenerateObserver;
use super::population::Population;
use super::schema::{SensorAxis, ShardInfo, PARAMETER_COLUMNS};
use super::writer::InstanceRow;
use super::BankError;
use crate::model::{batch_key, CheckedCalibration, Flat, Record, Simulator, LANES};
use rayon::prelude::*;

/// Simulates the rows of shard `info`, in instance order.
pub(crate) fn simulate_rows(
    sim: &Simulator,
    cal: &CheckedCalibration,
    population: &Population,
    axes: &[SensorAxis],
    info: &ShardInfo,
    observer: &dyn GenerateObserver,
) -> Result<Vec<InstanceRow>, BankError> {
    let instances = info.first_instance..info.first_instance + info.rows;
    let flats: Vec<(usize, Flat, [f64; PARAMETER_COLUMNS.len()], f64)> = instances
        .map(|i| {
            let s = population.instance(i);
            let flat = s
                .flat(cal.vehicle.flat_wheel)
                .map_err(|e| BankError::Instance {
                    instance: i,
                    message: e.to_string(),
                })?;
            let l0_mm = flat.fresh_length_m(cal.vehicle.wheel_radius_m) * 1e3;
            let parameters = [
                s.length_mm,
                s.depth_mm,
                s.curvature_mm,
                s.impact_position_m,
                l0_mm,
                flat.wheel().unwrap_or(cal.vehicle.flat_wheel).index() as f64,
                // The peak contact force, filled in once simulated.
                0.0,
            ];
            let key = batch_key(sim, Some(&flat));
            Ok((i, flat, parameters, key))
        })
        .collect::<Result<_, BankError>>()?;
    let mut order: Vec<usize> = (0..flats.len()).collect();
    order.sort_by(|&a, &b| flats[a].3.total_cmp(&flats[b].3).then(a.cmp(&b)));
    let batches: Vec<&[usize]> = order.chunks(LANES).collect();

    let done: Vec<Vec<(usize, InstanceRow)>> = batches
        .par_iter()
        .map_init(
            || sim.lane_workspace::<LANES>(),
            |ws, batch| {
                let members: Vec<Option<&Flat>> =
                    batch.iter().map(|&k| Some(&flats[k].1)).collect();
                let (results, _) = sim.run_batch(&members, Record::default(), ws);
                let mut rows = Vec::with_capacity(batch.len());
                for (&k, resp) in batch.iter().zip(results) {
                    let (i, flat, parameters, _) = &flats[k];
                    let resp = resp.map_err(|e| BankError::Instance {
                        instance: *i,
                        message: e.to_string(),
                    })?;
                    let mut forces_kn = Vec::with_capacity(axes.iter().map(|a| a.samples).sum());
                    for (si, a) in axes.iter().enumerate() {
                        forces_kn.extend(
                            resp.window(si, a.first_sample, a.samples)
                                .iter()
                                .map(|v| (v / 1e3) as f32),
                        );
                    }
                    let mut parameters = *parameters;
                    let wheel = flat.wheel().unwrap_or(cal.vehicle.flat_wheel).index();
                    parameters[PARAMETER_COLUMNS.len() - 1] =
                        resp.peak_contact_force_n[wheel] / 1e3;
                    observer.instance_done();
                    rows.push((
                        k,
                        InstanceRow {
                            instance: *i as u32,
                            parameters,
                            forces_kn,
                        },
                    ));
                }
                Ok(rows)
            },
        )
        .collect::<Result<_, BankError>>()?;
    let mut rows: Vec<Option<InstanceRow>> = (0..flats.len()).map(|_| None).collect();
    for (k, row) in done.into_iter().flatten() {
        rows[k] = Some(row);
    }
    Ok(rows
        .into_iter()
        .map(|r| r.expect("every instance is in one batch"))
        .collect())
}
