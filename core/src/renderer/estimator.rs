//! Which estimator renders, with the settings only it reads: one setting
//! for the whole choice (the CLI's `--method`, the C API's
//! `cmlt_renderer_config::estimator` with its fields), so a setting can
//! neither pick another estimator nor be given to one that ignores it.

use crate::mlt::{CmltSettings, Level2Settings, MltSettings};

/// The estimator and its own settings.
///
/// Settings every estimator reads (path depth, seed, workers, frame
/// switches) are in [`super::RendererConfig`]; those only the Metropolis
/// estimators read are in their variants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Estimator {
    /// Path tracing with next-event estimation and MIS.
    Path,
    /// Bidirectional path tracing with MIS over all strategies.
    Bdpt,
    /// Metropolis light transport: Kelemen mutations in primary sample
    /// space over BDPT's strategies (level 1 only).
    Mlt(MltSettings),
    /// Coherent MLT (Segovia 2007): MLT's level 1 plus side chains of lens,
    /// caustic and multi-chain perturbations traced as packets (level 2).
    Cmlt(CmltSettings),
}

/// The name of an estimator without its settings: what the CLI's
/// `--method`, the benchmarks and the C API's `CMLT_ESTIMATOR_*` constants
/// (whose values are the discriminants) choose.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum EstimatorKind {
    /// [`Estimator::Path`].
    Path = 0,
    /// [`Estimator::Bdpt`].
    Bdpt = 1,
    /// [`Estimator::Mlt`].
    Mlt = 2,
    /// [`Estimator::Cmlt`].
    Cmlt = 3,
}

impl EstimatorKind {
    /// Every estimator, in discriminant order.
    pub const ALL: [EstimatorKind; 4] = [
        EstimatorKind::Path,
        EstimatorKind::Bdpt,
        EstimatorKind::Mlt,
        EstimatorKind::Cmlt,
    ];

    /// The short name the CLI and the benchmarks use: `pt`, `bdpt`, `mlt`,
    /// `cmlt`.
    pub fn name(self) -> &'static str {
        match self {
            EstimatorKind::Path => "pt",
            EstimatorKind::Bdpt => "bdpt",
            EstimatorKind::Mlt => "mlt",
            EstimatorKind::Cmlt => "cmlt",
        }
    }

    /// The estimator of a short name ([`EstimatorKind::name`]).
    pub fn from_name(name: &str) -> Option<EstimatorKind> {
        EstimatorKind::ALL.into_iter().find(|e| e.name() == name)
    }

    /// The estimator of a C API constant (its discriminant).
    pub fn from_u32(value: u32) -> Option<EstimatorKind> {
        EstimatorKind::ALL.get(value as usize).copied()
    }

    /// Whether it runs Markov chains (MLT, CMLT) rather than passes of
    /// independent samples (PT, BDPT): budgets count mutations, not
    /// samples, and the image is normalised by the bootstrap's b.
    pub fn is_metropolis(self) -> bool {
        matches!(self, EstimatorKind::Mlt | EstimatorKind::Cmlt)
    }
}

impl Estimator {
    /// The estimator `kind` with its default settings: MLT's
    /// [`MltSettings::default`], CMLT's [`CmltSettings::default`] (level 1
    /// as MLT's, level 2 the measured [`Level2Settings::default`]).
    pub fn default_for(kind: EstimatorKind) -> Estimator {
        match kind {
            EstimatorKind::Path => Estimator::Path,
            EstimatorKind::Bdpt => Estimator::Bdpt,
            EstimatorKind::Mlt => Estimator::Mlt(MltSettings::default()),
            EstimatorKind::Cmlt => Estimator::Cmlt(CmltSettings::default()),
        }
    }

    /// Which estimator this is.
    pub fn kind(&self) -> EstimatorKind {
        match self {
            Estimator::Path => EstimatorKind::Path,
            Estimator::Bdpt => EstimatorKind::Bdpt,
            Estimator::Mlt(_) => EstimatorKind::Mlt,
            Estimator::Cmlt(_) => EstimatorKind::Cmlt,
        }
    }

    /// Whether it runs Markov chains ([`EstimatorKind::is_metropolis`]).
    pub fn is_metropolis(&self) -> bool {
        self.kind().is_metropolis()
    }

    /// The level-1 Metropolis settings (MLT's, or CMLT's level 1); `None`
    /// for PT and BDPT.
    pub fn mlt(&self) -> Option<&MltSettings> {
        match self {
            Estimator::Mlt(m) => Some(m),
            Estimator::Cmlt(c) => Some(&c.mlt),
            Estimator::Path | Estimator::Bdpt => None,
        }
    }

    /// The level-1 Metropolis settings to change in place; `None` for PT
    /// and BDPT.
    pub fn mlt_mut(&mut self) -> Option<&mut MltSettings> {
        match self {
            Estimator::Mlt(m) => Some(m),
            Estimator::Cmlt(c) => Some(&mut c.mlt),
            Estimator::Path | Estimator::Bdpt => None,
        }
    }

    /// CMLT's level-2 settings; `None` for the others.
    pub fn level2(&self) -> Option<&Level2Settings> {
        match self {
            Estimator::Cmlt(c) => Some(&c.level2),
            _ => None,
        }
    }

    /// Checks the estimator's settings; the message names the first bad
    /// one.
    pub fn validate(&self) -> Result<(), &'static str> {
        match self {
            Estimator::Path | Estimator::Bdpt => Ok(()),
            Estimator::Mlt(m) => m.validate(),
            Estimator::Cmlt(c) => c.validate(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mlt::Level1;

    #[test]
    fn kinds_round_trip_through_names_and_constants() {
        for (i, kind) in EstimatorKind::ALL.into_iter().enumerate() {
            assert_eq!(kind as u32, i as u32);
            assert_eq!(EstimatorKind::from_u32(i as u32), Some(kind));
            assert_eq!(EstimatorKind::from_name(kind.name()), Some(kind));
            assert_eq!(Estimator::default_for(kind).kind(), kind);
        }
        assert_eq!(EstimatorKind::from_u32(4), None);
        assert_eq!(EstimatorKind::from_name("MLT"), None);
    }

    #[test]
    fn each_estimator_carries_only_its_settings() {
        let pt = Estimator::default_for(EstimatorKind::Path);
        assert_eq!((pt.mlt(), pt.level2()), (None, None));
        let mlt = Estimator::default_for(EstimatorKind::Mlt);
        assert_eq!(mlt.mlt(), Some(&MltSettings::default()));
        assert_eq!(mlt.level2(), None);
        let cmlt = Estimator::default_for(EstimatorKind::Cmlt);
        // CMLT's level 1 is MLT's, defaults included.
        assert_eq!(cmlt.mlt(), mlt.mlt());
        assert_eq!(cmlt.level2(), Some(&Level2Settings::default()));
        for kind in EstimatorKind::ALL {
            assert_eq!(Estimator::default_for(kind).validate(), Ok(()));
        }
    }

    #[test]
    fn level_one_defaults_to_primary_sample_space() {
        assert_eq!(MltSettings::default().level1, Level1::PrimarySample);
        assert_eq!(Level1::default(), Level1::PrimarySample);
    }

    #[test]
    fn cmlt_without_side_chains_is_refused() {
        let mut c = CmltSettings::default();
        c.level2.m = 0;
        assert_eq!(
            Estimator::Cmlt(c).validate(),
            Err("CMLT needs m ≥ 1 side-chain steps")
        );
    }
}
