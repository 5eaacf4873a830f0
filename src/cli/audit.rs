//! `wheelflat audit`: one instance re-simulated and, with a measurement, judged point by point.

use super::args::AuditArgs;
use super::{create_output_folder, open_bank_at, open_identifier, write_file};
use anyhow::Result;
use wheelflat::audit::{check_against, compare, Resimulator};
use wheelflat::bank::Bank;
use wheelflat::report::audit::draw_audit;
use wheelflat::report::tables::{
    audit_instance_line, audit_json, audit_panels, audit_table, audit_title,
};

/// Re-simulates the instance, prints the verdict (and the table against a measurement), and
/// writes `audit.json` and `audit.png` when given a folder.
pub(super) fn run(a: &AuditArgs) -> Result<()> {
    // With a measurement, the bank (a family's member) its speed picks; without, the bank or
    // the member `--speed` names.
    let opened = match &a.measured {
        Some(measured) => Ok(open_identifier(
            &a.bank,
            measured,
            a.calibration.as_deref(),
            a.speed,
            false,
        )?),
        None => Err(open_bank_at(&a.bank, a.speed)?),
    };
    let b: &Bank = match &opened {
        Ok((identifier, _)) => identifier.bank(),
        Err(bank) => bank,
    };
    let stored = b.read_instance(a.instance)?;
    println!("{}", audit_instance_line(&stored));
    let resim = Resimulator::new(b, None)?;
    let series = resim.run(&stored, &mut resim.workspace())?;
    let comparison = compare(&stored, &series, b);
    println!(
        "re-simulated with the bank's stored calibration (bank id {}): {}",
        b.metadata().bank_id,
        comparison.verdict()
    );
    if !comparison.identical {
        println!("  the code or its calibration handling changed since this bank was built");
    }
    let mut check = None;
    let mut identification = None;
    if let Ok((identifier, m)) = &opened {
        let id = identifier.identify(m, a.sensors.as_deref(), wheelflat::identify::Extras::NONE)?;
        match check_against(identifier, &id, &stored)? {
            Some(c) => {
                print!("{}", audit_table(&c));
                check = Some(c);
            }
            None => println!(
                "not checked against {}: no flat detected, so the pass was not sized and there are no comparison points ({})",
                id.measurement, id.summary
            ),
        }
        identification = Some(id);
    }
    if let Some(out) = &a.out {
        create_output_folder(out)?;
        let json = audit_json(&stored, &b.metadata().bank_id, &comparison, check.as_ref());
        let json_path = out.join("audit.json");
        write_file(
            &json_path,
            serde_json::to_string_pretty(&json)
                .expect("audit serialises")
                .as_bytes(),
        )?;
        let png = out.join("audit.png");
        let panels = audit_panels(
            &b.metadata().sensors,
            &stored,
            &series,
            identification.as_ref(),
            check.as_ref(),
        );
        draw_audit(&audit_title(&stored, check.as_ref()), &panels, &png)?;
        println!("wrote {} and {}", json_path.display(), png.display());
    }
    Ok(())
}
