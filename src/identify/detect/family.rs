//! The identifiers of a bank family's members ([`crate::bank::family`]), each opened the first
//! time a pass at its speed needs it and kept open after (a resident `watch`, a train whose
//! bogies run at several speeds).

use crate::bank::family::Family;
use crate::identify::domain::load_shapes::LoadShapes;
use crate::identify::error::IdentifyError;
use crate::identify::identifier::Identifier;
use crate::identify::input::measurement::Measurement;
use crate::model::calibration::IdentificationParams;
use std::path::Path;
use std::sync::Arc;

/// A family (or a single bank) and the identifiers opened on its members so far.
pub struct Members {
    family: Family,
    /// Settings for every member (`None`: each member's stored ones).
    settings: Option<IdentificationParams>,
    open: Vec<Option<Identifier>>,
    /// The members' shapes by load, per speed (keyed by the first member at that speed),
    /// read when a pass at that speed first needs them.
    shapes: std::collections::HashMap<usize, Option<Arc<LoadShapes>>>,
}

impl Members {
    /// Opens `dir` (a family or a single bank; a single bank's identifier is built at once).
    pub fn open(
        dir: &Path,
        settings: Option<IdentificationParams>,
    ) -> Result<Members, IdentifyError> {
        let (family, single) = Family::open(dir)?;
        let mut open: Vec<Option<Identifier>> = family.members.iter().map(|_| None).collect();
        if let Some(bank) = single {
            open[0] = Some(identifier(bank, &settings)?);
        }
        Ok(Members {
            family,
            settings,
            open,
            shapes: std::collections::HashMap::new(),
        })
    }

    /// The family.
    pub fn family(&self) -> &Family {
        &self.family
    }

    /// The member a pass at `speed_km_per_h` is compared with, opened if it was not yet;
    /// its index for [`Members::get`]. A speed no member covers is an error naming the band.
    pub fn member_for(&mut self, speed_km_per_h: f64) -> Result<usize, IdentifyError> {
        let k = self.family.member_for(speed_km_per_h)?;
        self.open_member(k)?;
        Ok(k)
    }

    /// The member a pass is compared with, opened: the member at its speed
    /// (`m.speed_km_per_h`, which the caller states), and among the members at that speed the
    /// one nearest the load its record shows, read on the member nearest the calibration's own
    /// load ([`Identifier::estimate_load`]). A single bank, or a family without loads, is
    /// checked the same way: a load outside every member's tolerances
    /// ([`crate::bank::loads::nearest_load`]) is refused with the loads covered named. `nearest`: the nearest member
    /// however far (diagnosis, which lets the record say what it is). `sensors` as for
    /// [`Identifier::identify`].
    pub fn member_for_pass(
        &mut self,
        m: &Measurement,
        sensors: Option<&[String]>,
        nearest: bool,
    ) -> Result<usize, IdentifyError> {
        let v = m.speed_km_per_h.ok_or_else(|| IdentifyError::NoSpeed {
            path: m.path.clone(),
        })?;
        let k = if nearest {
            self.family.nearest_member(v)
        } else {
            self.family.member_for(v)?
        };
        let at_speed = self.family.at_speed_of(k);
        // The member nearest the calibration's own load reads the record's.
        let own = at_speed
            .iter()
            .copied()
            .min_by(|&a, &b| {
                let f = |j: usize| {
                    self.family.members[j]
                        .load_factor
                        .map_or(0.0, |x| (x - 1.0).abs())
                };
                f(a).total_cmp(&f(b))
            })
            .expect("a speed has members");
        // Opened before the shapes are read: they take its metadata from it, not from disk.
        self.open_member(own)?;
        let shapes = self.shapes_at(&at_speed)?;
        self.open_with_shapes(own, &shapes)?;
        // Nearest however far (diagnosis): the record is read at the member's speed, which
        // the diagnosis then questions.
        let at_member;
        let m = match nearest {
            true => {
                at_member = Measurement {
                    speed_km_per_h: Some(self.family.members[own].speed_km_per_h),
                    ..m.clone()
                };
                &at_member
            }
            false => m,
        };
        let Some(load) = self.get(own).estimate_load(m, sensors)? else {
            return Ok(own);
        };
        let loads_kn: Vec<f64> = at_speed
            .iter()
            .map(|&j| match self.family.loads {
                Some(_) => self.family.members[j].wheel_load_kn,
                None => load.bank_wheel_load_kn,
            })
            .collect();
        let k = self
            .family
            .member_for_load(&at_speed, &loads_kn, load.wheel_load_kn, nearest)
            .map_err(|refusal| IdentifyError::Load {
                refusal,
                interval_kn: load.interval_kn,
                probability: crate::identify::detect::load::LOAD_INTERVAL_PROBABILITY,
                car_body_mass_kg: load.car_body_mass_kg,
            })?;
        self.open_with_shapes(k, &shapes)?;
        Ok(k)
    }

    /// Any member's identifier (one already open, else the middle member, opened): for what
    /// every member shares (sample rate, sensors, vehicle).
    pub fn any(&mut self) -> Result<&Identifier, IdentifyError> {
        let k = match self.open.iter().position(Option::is_some) {
            Some(k) => k,
            None => {
                let k = self.open.len() / 2;
                self.open_member(k)?;
                k
            }
        };
        Ok(self.get(k))
    }

    /// The identifier of an opened member.
    ///
    /// # Panics
    /// When member `k` was not opened by [`Members::member_for`], [`Members::open_member`] or
    /// [`Members::any`].
    pub fn get(&self, k: usize) -> &Identifier {
        self.open[k]
            .as_ref()
            .expect("a member is opened by member_for before it is used")
    }

    /// Takes the identifier of an opened member out (for one-shot commands).
    ///
    /// # Panics
    /// As [`Members::get`].
    pub fn take(mut self, k: usize) -> Identifier {
        self.open[k]
            .take()
            .expect("a member is opened by member_for before it is used")
    }

    /// The flat-free predictions of the members `at_speed` by load, on a family over loads
    /// with two or more there ([`LoadShapes`]): each member's bank opened for its metadata
    /// (the members not yet identified with stay closed after).
    fn shapes_at(&mut self, at_speed: &[usize]) -> Result<Option<Arc<LoadShapes>>, IdentifyError> {
        if self.family.loads.is_none() || at_speed.len() < 2 {
            return Ok(None);
        }
        if let Some(s) = self.shapes.get(&at_speed[0]) {
            return Ok(s.clone());
        }
        let mut members = Vec::with_capacity(at_speed.len());
        for &j in at_speed {
            let flat_free = match &self.open[j] {
                Some(id) => id.bank().metadata().flat_free_kn.clone(),
                None => self.family.members[j]
                    .open()?
                    .metadata()
                    .flat_free_kn
                    .clone(),
            };
            members.push((self.family.members[j].wheel_load_kn, flat_free));
        }
        let s = LoadShapes::new(members).map(Arc::new);
        self.shapes.insert(at_speed[0], s.clone());
        Ok(s)
    }

    /// The members next to member `k` by load at its speed (the lighter and the heavier one,
    /// the nearer in wheel load first), opened with the load shapes of that speed; none for a
    /// family without loads.
    pub fn load_neighbours(&mut self, k: usize) -> Result<Vec<usize>, IdentifyError> {
        if self.family.loads.is_none() {
            return Ok(Vec::new());
        }
        let at_speed = self.family.at_speed_of(k);
        let Some(i) = at_speed.iter().position(|&j| j == k) else {
            return Ok(Vec::new());
        };
        let mut out: Vec<usize> = [i.checked_sub(1), Some(i + 1)]
            .into_iter()
            .flatten()
            .filter_map(|t| at_speed.get(t).copied())
            .collect();
        let load = |j: usize| self.family.members[j].wheel_load_kn;
        let own = load(k);
        out.sort_by(|&a, &b| (load(a) - own).abs().total_cmp(&(load(b) - own).abs()));
        let shapes = self.shapes_at(&at_speed)?;
        for &j in &out {
            self.open_with_shapes(j, &shapes)?;
        }
        Ok(out)
    }

    /// Opens member `j` (if it is not open yet) and gives it the load shapes of its speed.
    fn open_with_shapes(
        &mut self,
        j: usize,
        shapes: &Option<Arc<LoadShapes>>,
    ) -> Result<(), IdentifyError> {
        self.open_member(j)?;
        self.open[j]
            .as_mut()
            .expect("opened above")
            .set_load_shapes(shapes.clone());
        Ok(())
    }

    /// Opens member `k` if it is not open yet (`k` as [`Family::member_for`] gives it).
    pub fn open_member(&mut self, k: usize) -> Result<(), IdentifyError> {
        if self.open[k].is_none() {
            let bank = self.family.members[k].open()?;
            self.open[k] = Some(identifier(bank, &self.settings)?);
        }
        Ok(())
    }
}

/// An identifier on `bank` with `settings`, or the bank's own when `None`.
fn identifier(
    bank: crate::bank::Bank,
    settings: &Option<IdentificationParams>,
) -> Result<Identifier, IdentifyError> {
    let s = settings
        .clone()
        .unwrap_or_else(|| bank.metadata().calibration.identification.clone());
    Identifier::new(bank, s)
}
