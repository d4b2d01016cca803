//! Mergeable render state: what `cmlt render --part I/N --state FILE`
//! writes and `cmlt merge` reads back, so one image can be rendered as N
//! independent parts on N processes or machines and merged.
//!
//! A part holds the unscaled film sums of all its workers (the camera-sample
//! layer and the splat layer apart, f64), the counters that normalise them
//! (passes for PT and BDPT; level-1 mutations and records for MLT and CMLT)
//! and, for the Metropolis estimators, the bootstrap's b per path depth with
//! the number of samples behind it (the tallies that pool b across parts).
//! The header names everything the parts must share: the scene's hash, the
//! estimator and every setting, the base seed, the resolution and the part
//! count N.
//!
//! Parts differ only by their random streams: part I renders with the seed
//! [`part_seed`]`(seed, I)`, and every stream of a render is keyed by a
//! 64-bit hash of (seed, pass, pixel) or (seed, chain), so parts draw
//! from disjoint stream families (up to 64-bit hash collisions).
//!
//! ## File format (version 1, little-endian)
//!
//! ```text
//!   magic "CMLTPART"  version u32  payload length u64
//!   payload:
//!     part u32  parts u32  frame u64  width u32  height u32
//!     seed u64  part seed u64  scene hash u64
//!     estimator: u32 length + UTF-8   settings: u32 length + UTF-8
//!     passes u64  mutations u64  records u64  nonfinite u64
//!     b f64  tally count u64  depths u32  b_d f64 × depths
//!     render seconds f64  bootstrap seconds f64
//!     samples f64 × 3 × width × height   splats f64 × 3 × width × height
//!   checksum u64 (FNV-1a 64 of everything before it)
//! ```
//!
//! A reader checks the magic, the version, the payload length against the
//! file's, every length inside against what is left, and the checksum; a
//! truncated, corrupt or foreign file is refused with a message naming it.

use std::path::Path;

use cmlt::math::Rgb;
use cmlt::mlt::image_scale;
use cmlt::renderer::{EstimatorKind, RendererConfig};
use cmlt::sampler::mix64;

use crate::image_io::{Image, write_atomically};
use crate::render::{FilmSums, RenderOutput};

/// The file's first eight bytes.
pub const MAGIC: &[u8; 8] = b"CMLTPART";

/// The format version this build writes and reads.
pub const VERSION: u32 = 1;

/// Largest part count `--part I/N` accepts.
pub const MAX_PARTS: u32 = 1 << 20;

/// Bytes before the payload: magic, version, payload length.
const PREFIX: usize = 8 + 4 + 8;

/// The seed part `part` renders with: the base seed itself for part 0 (so
/// `--part 0/N` renders exactly what a plain render with `--seed` does),
/// a SplitMix64 hash of (seed, part) otherwise.
pub fn part_seed(seed: u64, part: u32) -> u64 {
    if part == 0 {
        seed
    } else {
        mix64(mix64(seed ^ 0x5041_5254_0000_0000) ^ part as u64)
    }
}

/// FNV-1a, 64 bits: the checksum of a state file and the scene hash (not
/// cryptographic: it catches corruption and mix-ups, not forgery).
#[derive(Clone, Copy, Debug)]
pub struct Fnv64(u64);

impl Default for Fnv64 {
    fn default() -> Self {
        Fnv64(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv64 {
    /// Hashes `bytes` into the state.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    /// The hash of everything written.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The scene's identity for merging: the scene file's bytes (or the
/// built-in scene's name when no such file exists), the `-D` defines in
/// order, and every triangle's vertices as loaded (which covers the meshes
/// the file refers to).
pub fn scene_hash(
    name: &str,
    defines: &[(String, String)],
    triangles: impl Iterator<Item = [cmlt::math::Vec3; 3]>,
) -> u64 {
    let mut h = Fnv64::default();
    match std::fs::read(name) {
        Ok(bytes) => h.write(&bytes),
        Err(_) => h.write(name.as_bytes()),
    }
    for (k, v) in defines {
        h.write(k.as_bytes());
        h.write(b"=");
        h.write(v.as_bytes());
        h.write(b"\0");
    }
    for t in triangles {
        for v in t {
            for c in v.to_array() {
                h.write(&c.to_bits().to_le_bytes());
            }
        }
    }
    h.finish()
}

/// One part's mergeable state (see the module docs for the file format).
#[derive(Clone, Debug, PartialEq)]
pub struct PartState {
    /// This part's index I (< `parts`).
    pub part: u32,
    /// The number of parts N the image was split into.
    pub parts: u32,
    /// Frame number (0 for a single image).
    pub frame: u64,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// The base seed (`--seed`), shared by all parts.
    pub seed: u64,
    /// The seed this part rendered with ([`part_seed`]).
    pub part_seed: u64,
    /// [`scene_hash`] of the scene rendered.
    pub scene_hash: u64,
    /// The estimator's name (`pt`, `bdpt`, `mlt`, `cmlt`).
    pub estimator: String,
    /// Every setting that changes the image, as text (parts merge only
    /// when these are equal byte for byte).
    pub settings: String,
    /// Passes (one sample per pixel) summed over workers (PT, BDPT).
    pub passes: u64,
    /// Level-1 mutations (MLT, CMLT).
    pub mutations: u64,
    /// Records splatted, the Metropolis film's normaliser (MLT, CMLT).
    pub records: u64,
    /// Non-finite samples the films dropped.
    pub nonfinite: u64,
    /// The normalisation b this part's film was rendered with (MLT, CMLT;
    /// 0 otherwise).
    pub b: f64,
    /// Samples behind each b_d: normalisation passes × pixels, or bootstrap
    /// samples per depth when b comes from them (MLT, CMLT; 0 otherwise).
    pub tally_count: u64,
    /// b by path depth, `depth_b[d − 1]` for depth d (MLT, CMLT).
    pub depth_b: Vec<f64>,
    /// Wall-clock seconds of the render, bootstrap included.
    pub seconds: f64,
    /// Wall-clock seconds of the bootstrap.
    pub bootstrap_seconds: f64,
    /// Camera-sample sums per pixel, RGB, row-major.
    pub samples: Vec<[f64; 3]>,
    /// Splat sums per pixel, RGB, row-major.
    pub splats: Vec<[f64; 3]>,
}

impl PartState {
    /// The estimator, parsed from its name.
    pub fn estimator(&self) -> Option<EstimatorKind> {
        EstimatorKind::from_name(&self.estimator)
    }

    fn is_metropolis(&self) -> bool {
        self.estimator().is_some_and(|e| e.is_metropolis())
    }

    /// The file's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut p = Vec::with_capacity(256 + self.samples.len() * 48);
        put_u32(&mut p, self.part);
        put_u32(&mut p, self.parts);
        put_u64(&mut p, self.frame);
        put_u32(&mut p, self.width);
        put_u32(&mut p, self.height);
        put_u64(&mut p, self.seed);
        put_u64(&mut p, self.part_seed);
        put_u64(&mut p, self.scene_hash);
        put_str(&mut p, &self.estimator);
        put_str(&mut p, &self.settings);
        put_u64(&mut p, self.passes);
        put_u64(&mut p, self.mutations);
        put_u64(&mut p, self.records);
        put_u64(&mut p, self.nonfinite);
        put_f64(&mut p, self.b);
        put_u64(&mut p, self.tally_count);
        put_u32(&mut p, self.depth_b.len() as u32);
        for &d in &self.depth_b {
            put_f64(&mut p, d);
        }
        put_f64(&mut p, self.seconds);
        put_f64(&mut p, self.bootstrap_seconds);
        for layer in [&self.samples, &self.splats] {
            for px in layer.iter() {
                for &c in px {
                    put_f64(&mut p, c);
                }
            }
        }
        let mut out = Vec::with_capacity(PREFIX + p.len() + 8);
        out.extend_from_slice(MAGIC);
        put_u32(&mut out, VERSION);
        put_u64(&mut out, p.len() as u64);
        out.extend_from_slice(&p);
        let mut h = Fnv64::default();
        h.write(&out);
        put_u64(&mut out, h.finish());
        out
    }

    /// This state without its film (what [`PartState::read_header`]
    /// returns).
    pub fn header(&self) -> PartState {
        PartState {
            part: self.part,
            parts: self.parts,
            frame: self.frame,
            width: self.width,
            height: self.height,
            seed: self.seed,
            part_seed: self.part_seed,
            scene_hash: self.scene_hash,
            estimator: self.estimator.clone(),
            settings: self.settings.clone(),
            passes: self.passes,
            mutations: self.mutations,
            records: self.records,
            nonfinite: self.nonfinite,
            b: self.b,
            tally_count: self.tally_count,
            depth_b: self.depth_b.clone(),
            seconds: self.seconds,
            bootstrap_seconds: self.bootstrap_seconds,
            samples: Vec::new(),
            splats: Vec::new(),
        }
    }

    /// Reads the header of the state file at `path` (everything but the
    /// film), checking the magic, version and lengths but not the checksum,
    /// which needs the whole file ([`PartState::read`]).
    pub fn read_header(path: &Path) -> Result<Self, String> {
        use std::io::Read;
        let name = path.display().to_string();
        let mut f = std::fs::File::open(path).map_err(|e| format!("{name}: cannot read: {e}"))?;
        let len = f
            .metadata()
            .map_err(|e| format!("{name}: cannot read: {e}"))?
            .len();
        // A header is a few hundred bytes (the settings text, b per depth:
        // at most 1024 depths).
        let mut head = Vec::new();
        f.by_ref()
            .take(64 * 1024)
            .read_to_end(&mut head)
            .map_err(|e| format!("{name}: cannot read: {e}"))?;
        Self::parse(&head, Some(len), &name)
    }

    /// Checks the checksum of the state file at `path`, reading it in
    /// blocks (nothing is kept).
    pub fn verify_file(path: &Path) -> Result<(), String> {
        use std::io::Read;
        let name = path.display();
        let io = |e: std::io::Error| format!("{name}: cannot read: {e}");
        let mut f = std::fs::File::open(path).map_err(io)?;
        let len = f.metadata().map_err(io)?.len();
        if len < (PREFIX + 8) as u64 {
            return Err(format!(
                "{name}: not a valid cmlt part state: truncated header"
            ));
        }
        let mut h = Fnv64::default();
        let mut left = len - 8;
        let mut buf = vec![0u8; 1 << 20];
        while left > 0 {
            let k = left.min(buf.len() as u64) as usize;
            f.read_exact(&mut buf[..k]).map_err(io)?;
            h.write(&buf[..k]);
            left -= k as u64;
        }
        let mut stored = [0u8; 8];
        f.read_exact(&mut stored).map_err(io)?;
        if h.finish() != u64::from_le_bytes(stored) {
            return Err(format!(
                "{name}: not a valid cmlt part state: checksum mismatch (the file is corrupt)"
            ));
        }
        Ok(())
    }

    /// Parses a state file's bytes; `name` labels the errors.
    pub fn from_bytes(bytes: &[u8], name: &str) -> Result<Self, String> {
        Self::parse(bytes, None, name)
    }

    /// Parses a whole file (`file_len` None: checksum and film checked) or
    /// the head of a file of `file_len` bytes (header only).
    fn parse(bytes: &[u8], file_len: Option<u64>, name: &str) -> Result<Self, String> {
        let whole = file_len.is_none();
        let file_len = file_len.unwrap_or(bytes.len() as u64);
        let bad = |what: &str| format!("{name}: not a valid cmlt part state: {what}");
        if bytes.len() < 8 || &bytes[..8] != MAGIC {
            return Err(bad("wrong magic (not written by cmlt render --state)"));
        }
        if bytes.len() < PREFIX {
            return Err(bad("truncated header"));
        }
        let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
        if version != VERSION {
            return Err(format!(
                "{name}: part state version {version}, this cmlt reads version {VERSION} (render the part again with this build)"
            ));
        }
        let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap());
        let expected = (PREFIX as u64)
            .checked_add(len)
            .and_then(|n| n.checked_add(8));
        if expected != Some(file_len) {
            return Err(bad(&format!(
                "{file_len} bytes, the header announces {} (truncated or padded)",
                expected.map_or("more than 2^64".to_string(), |n| n.to_string())
            )));
        }
        let body_end = if whole {
            let body_end = bytes.len() - 8;
            let mut h = Fnv64::default();
            h.write(&bytes[..body_end]);
            let stored = u64::from_le_bytes(bytes[body_end..].try_into().unwrap());
            if h.finish() != stored {
                return Err(bad("checksum mismatch (the file is corrupt)"));
            }
            body_end
        } else {
            bytes.len()
        };
        let mut r = Reader {
            bytes: &bytes[PREFIX..body_end],
        };
        let mut s = PartState {
            part: r.u32()?,
            parts: r.u32()?,
            frame: r.u64()?,
            width: r.u32()?,
            height: r.u32()?,
            seed: r.u64()?,
            part_seed: r.u64()?,
            scene_hash: r.u64()?,
            estimator: r.string()?,
            settings: r.string()?,
            passes: r.u64()?,
            mutations: r.u64()?,
            records: r.u64()?,
            nonfinite: r.u64()?,
            b: r.f64()?,
            tally_count: r.u64()?,
            depth_b: Vec::new(),
            seconds: 0.0,
            bootstrap_seconds: 0.0,
            samples: Vec::new(),
            splats: Vec::new(),
        };
        let depths = r.u32()? as usize;
        if depths > r.bytes.len() / 8 {
            return Err(bad("depth count beyond the file"));
        }
        s.depth_b = (0..depths).map(|_| r.f64()).collect::<Result<_, _>>()?;
        s.seconds = r.f64()?;
        s.bootstrap_seconds = r.f64()?;
        let pixels = s.width as u64 * s.height as u64;
        // The film is the rest of the payload, up to the checksum.
        let film = file_len.saturating_sub(8 + (body_end - r.bytes.len()) as u64);
        if pixels.checked_mul(48) != Some(film) {
            return Err(bad(&format!(
                "{}x{} pixels need {} bytes of film, the file has {film}",
                s.width,
                s.height,
                pixels.saturating_mul(48),
            )));
        }
        if !whole {
            s.check_header().map_err(|e| bad(&e))?;
            return Ok(s);
        }
        for layer in [&mut s.samples, &mut s.splats] {
            *layer = (0..pixels)
                .map(|_| Ok([r.f64()?, r.f64()?, r.f64()?]))
                .collect::<Result<_, String>>()?;
        }
        s.check().map_err(|e| bad(&e))?;
        Ok(s)
    }

    /// Checks the header's and the film's values.
    fn check(&self) -> Result<(), String> {
        self.check_header()?;
        if self
            .samples
            .iter()
            .chain(&self.splats)
            .flatten()
            .any(|c| !c.is_finite())
        {
            return Err("a film sum is not finite".to_string());
        }
        Ok(())
    }

    /// Checks the header's values for consistency.
    fn check_header(&self) -> Result<(), String> {
        if self.parts == 0 || self.part >= self.parts {
            return Err(format!("part {} of {}", self.part, self.parts));
        }
        if self.estimator().is_none() {
            return Err(format!("unknown estimator '{}'", self.estimator));
        }
        if !(self.b.is_finite() && self.b >= 0.0) || self.depth_b.iter().any(|d| !d.is_finite()) {
            return Err("b is not finite".to_string());
        }
        if self
            .samples
            .iter()
            .chain(&self.splats)
            .flatten()
            .any(|c| !c.is_finite())
        {
            return Err("a film sum is not finite".to_string());
        }
        Ok(())
    }

    /// Writes the state to `path` atomically (a temporary file renamed
    /// over `path`).
    pub fn write(&self, path: &Path) -> Result<(), String> {
        write_atomically(path, &self.to_bytes())
    }

    /// Reads and checks the state file at `path`.
    pub fn read(path: &Path) -> Result<Self, String> {
        let bytes =
            std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
        Self::from_bytes(&bytes, &path.display().to_string())
    }

    /// The image of this part alone (what its render resolved).
    pub fn resolve(&self) -> Image {
        // One part is a merge of one: the same arithmetic, bit for bit.
        merge(std::slice::from_ref(self))
            .expect("a lone part merges")
            .image
    }
}

/// Which part of which render a state is.
#[derive(Clone, Copy, Debug)]
pub struct Identity {
    /// Part index I.
    pub part: u32,
    /// Part count N.
    pub parts: u32,
    /// Frame number (0 for a single image).
    pub frame: u64,
    /// The base seed (`--seed`; the part rendered with [`part_seed`]).
    pub seed: u64,
    /// [`scene_hash`] of the scene.
    pub scene_hash: u64,
}

/// The settings text two parts must share: the configuration with every
/// field (path depth and its cap, the estimator with its settings, frame
/// switches, effects), seed and worker count aside.
pub fn settings_text(config: &RendererConfig) -> String {
    format!(
        "{:?} depth_cap {} {:?} {:?} all_effects {}",
        config.settings, config.depth_cap, config.estimator, config.temporal, config.all_effects
    )
}

/// The state of a finished render ([`crate::render::render_with_sums`])
/// rendered with `config` as part `id.part` of `id.parts`.
pub fn from_render(
    out: &RenderOutput,
    sums: FilmSums,
    config: &RendererConfig,
    id: Identity,
) -> PartState {
    let pixels = (out.image.width * out.image.height) as u64;
    let (b, tally_count, depth_b) = match (&out.bootstrap, config.estimator.mlt()) {
        (Some(boot), Some(m)) => {
            // Each b_d is a mean over the normalisation passes' pixels, or
            // over the bootstrap samples of its depth without passes.
            let count = if m.b_passes > 0 {
                u64::from(m.normalisation_passes(pixels)) * pixels
            } else {
                m.n_bootstrap as u64
            };
            (out.stats.b, count, boot.depth_b().to_vec())
        }
        _ => (0.0, 0, Vec::new()),
    };
    PartState {
        part: id.part,
        parts: id.parts,
        frame: id.frame,
        width: out.image.width as u32,
        height: out.image.height as u32,
        seed: id.seed,
        part_seed: config.seed,
        scene_hash: id.scene_hash,
        estimator: config.estimator.kind().name().to_string(),
        settings: settings_text(config),
        passes: out.stats.passes,
        mutations: out.stats.mlt.mutations,
        records: out.stats.mlt.records,
        nonfinite: out.stats.nonfinite,
        b,
        tally_count,
        depth_b,
        seconds: out.wall.as_secs_f64(),
        bootstrap_seconds: out.bootstrap_wall.as_secs_f64(),
        samples: sums.samples,
        splats: sums.splats,
    }
}

/// What merging parts produced.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The image.
    pub image: Image,
    /// The pooled normalisation b (MLT, CMLT; 0 otherwise).
    pub b: f64,
    /// Passes (PT, BDPT) or level-1 mutations (MLT, CMLT) of all parts.
    pub units: u64,
    /// The part indices that were missing from 0..N (the image is still an
    /// unbiased estimate from the parts present, at a smaller budget).
    pub missing: Vec<u32>,
    /// Non-finite samples the parts' films dropped.
    pub nonfinite: u64,
}

/// Checks that `parts` belong to one render (same scene, estimator,
/// settings, seed, resolution, frame and part count N; distinct indices)
/// and merges them into the image a single process would have rendered
/// with the parts' budgets summed.
///
/// PT, BDPT: sample and splat sums add layer by layer, passes add.
///
/// MLT, CMLT: a part's film holds `records` unit-luminance splats whose
/// split between path depths was set by that part's own b_d / b (the
/// chains' depth weights), so a film is only meaningful with its own
/// bootstrap: part p enters with [`image_scale`]`(b_p, pixels, R)`, R the
/// records of all parts — the records-weighted mean of the parts' images,
/// whose depth d carries Σ_p (R_p / R) · b_{d,p}. That is multiplied by
/// b_pool / Σ_p (R_p / R) · b_p, b_pool = Σ_d Σ_p c_p · b_{d,p} / Σ_p c_p
/// from the bootstrap tallies (c_p samples each), so the merged image's
/// mean luminance is the pooled b: with equal budgets the two are equal
/// and each depth gets exactly the pooled b_d, the normalisation of one
/// bootstrap with all parts' samples (its variance divided by N).
pub fn merge(parts: &[PartState]) -> Result<Merged, String> {
    let headers: Vec<&PartState> = parts.iter().collect();
    let plan = plan(&headers)?;
    let mut acc = Accumulator::new(&plan, parts[0].samples.len());
    for (k, p) in parts.iter().enumerate() {
        acc.add(&plan, k, p);
    }
    Ok(acc.finish(plan, parts[0].width, parts[0].height))
}

/// [`merge`] of the state files at `paths`, holding one part in memory at a
/// time: every file's header is read and its checksum verified first, and
/// the headers checked against each other (nothing is accumulated for
/// parts that are corrupt or do not belong together); then each file is
/// read again, whole, and added.
pub fn merge_files(paths: &[impl AsRef<Path>]) -> Result<Merged, String> {
    let headers: Vec<PartState> = paths
        .iter()
        .map(|p| {
            let h = PartState::read_header(p.as_ref())?;
            PartState::verify_file(p.as_ref())?;
            Ok(h)
        })
        .collect::<Result<_, String>>()?;
    let refs: Vec<&PartState> = headers.iter().collect();
    let plan = plan(&refs)?;
    let Some(first) = headers.first() else {
        return Err("no parts to merge".to_string());
    };
    let mut acc = Accumulator::new(&plan, first.width as usize * first.height as usize);
    for (k, path) in paths.iter().enumerate() {
        let part = PartState::read(path.as_ref())?;
        if part.header() != headers[k] {
            return Err(format!(
                "{}: changed while it was being merged",
                path.as_ref().display()
            ));
        }
        acc.add(&plan, k, &part);
    }
    Ok(acc.finish(plan, first.width, first.height))
}

/// What the checks found and how each part is scaled.
struct Plan {
    metropolis: bool,
    /// Per part, the factor from its film sums to radiance (MLT, CMLT), or
    /// 1 / passes of all parts (PT, BDPT).
    scales: Vec<f64>,
    b: f64,
    units: u64,
    missing: Vec<u32>,
    nonfinite: u64,
}

/// Checks that the parts belong together and computes their scales.
fn plan(parts: &[&PartState]) -> Result<Plan, String> {
    let Some(first) = parts.first() else {
        return Err("no parts to merge".to_string());
    };
    let mut seen = vec![false; first.parts as usize];
    for (k, p) in parts.iter().enumerate() {
        let differs = |what: &str, a: &dyn std::fmt::Display, b: &dyn std::fmt::Display| {
            Err(format!(
                "part {k} (index {}) does not belong with part 0 (index {}): {what} differs ({b} against {a})",
                p.part, first.part
            ))
        };
        if p.scene_hash != first.scene_hash {
            return differs(
                "the scene (file bytes, -D defines or geometry)",
                &format!("hash {:016x}", first.scene_hash),
                &format!("hash {:016x}", p.scene_hash),
            );
        }
        if p.estimator != first.estimator {
            return differs("the method", &first.estimator, &p.estimator);
        }
        if p.settings != first.settings {
            return differs("the settings", &first.settings, &p.settings);
        }
        if (p.width, p.height) != (first.width, first.height) {
            return differs(
                "the resolution",
                &format!("{}x{}", first.width, first.height),
                &format!("{}x{}", p.width, p.height),
            );
        }
        if p.seed != first.seed {
            return differs("the base seed", &first.seed, &p.seed);
        }
        if p.parts != first.parts {
            return differs("the part count N", &first.parts, &p.parts);
        }
        if p.frame != first.frame {
            return differs("the frame", &first.frame, &p.frame);
        }
        if p.depth_b.len() != first.depth_b.len() {
            return differs("the path depths", &first.depth_b.len(), &p.depth_b.len());
        }
        // The same index twice would count the same random numbers twice:
        // an image that looks converged but is not.
        if std::mem::replace(&mut seen[p.part as usize], true) {
            return Err(format!(
                "part {} of {} is given twice: each index may be merged once",
                p.part, p.parts
            ));
        }
    }
    let missing: Vec<u32> = (0..first.parts).filter(|&i| !seen[i as usize]).collect();
    let pixels = first.width as u64 * first.height as u64;
    let metropolis = first.is_metropolis();
    let nonfinite = parts.iter().map(|p| p.nonfinite).sum();
    if !metropolis {
        let passes: u64 = parts.iter().map(|p| p.passes).sum();
        let inv = if passes == 0 {
            0.0
        } else {
            1.0 / passes as f64
        };
        return Ok(Plan {
            metropolis,
            scales: vec![inv; parts.len()],
            b: 0.0,
            units: passes,
            missing,
            nonfinite,
        });
    }
    let records: u64 = parts.iter().map(|p| p.records).sum();
    let mut scales: Vec<f64> = parts
        .iter()
        .map(|p| image_scale(p.b, pixels, records))
        .collect();
    let equal = parts
        .iter()
        .all(|p| p.records == first.records && p.tally_count == first.tally_count);
    let b_pool = pooled_b(parts);
    // With equal budgets b_pool is the records-weighted mean of the parts'
    // b exactly; skipping the ratio then keeps one part's merge
    // bit-identical to its own render.
    if !equal && records > 0 {
        let b_mean: f64 = parts
            .iter()
            .map(|p| p.records as f64 / records as f64 * p.b)
            .sum();
        if b_mean > 0.0 {
            for s in &mut scales {
                *s *= b_pool / b_mean;
            }
        }
    }
    Ok(Plan {
        metropolis,
        scales,
        b: b_pool,
        units: parts.iter().map(|p| p.mutations).sum(),
        missing,
        nonfinite,
    })
}

/// The merged image being summed: for PT and BDPT the sample and splat
/// layers apart (added at the end, as the renderer merges its workers'
/// films), for MLT and CMLT the scaled totals in `a`.
struct Accumulator {
    a: Vec<[f64; 3]>,
    b: Vec<[f64; 3]>,
}

impl Accumulator {
    fn new(plan: &Plan, pixels: usize) -> Self {
        Accumulator {
            a: vec![[0.0; 3]; pixels],
            b: if plan.metropolis {
                Vec::new()
            } else {
                vec![[0.0; 3]; pixels]
            },
        }
    }

    /// Adds part `k` of the plan.
    fn add(&mut self, plan: &Plan, k: usize, p: &PartState) {
        if plan.metropolis {
            let s = plan.scales[k];
            for (acc, (x, y)) in self.a.iter_mut().zip(p.samples.iter().zip(&p.splats)) {
                for c in 0..3 {
                    acc[c] += (x[c] + y[c]) * s;
                }
            }
        } else {
            for (acc, x) in self.a.iter_mut().zip(&p.samples) {
                for c in 0..3 {
                    acc[c] += x[c];
                }
            }
            for (acc, y) in self.b.iter_mut().zip(&p.splats) {
                for c in 0..3 {
                    acc[c] += y[c];
                }
            }
        }
    }

    fn finish(self, plan: Plan, width: u32, height: u32) -> Merged {
        let pixels = if plan.metropolis {
            self.a
                .iter()
                .map(|t| Rgb::new(t[0] as f32, t[1] as f32, t[2] as f32))
                .collect()
        } else {
            let s = plan.scales.first().copied().unwrap_or(0.0);
            self.a
                .iter()
                .zip(&self.b)
                .map(|(x, y)| {
                    Rgb::new(
                        ((x[0] + y[0]) * s) as f32,
                        ((x[1] + y[1]) * s) as f32,
                        ((x[2] + y[2]) * s) as f32,
                    )
                })
                .collect()
        };
        Merged {
            image: Image {
                width: width as usize,
                height: height as usize,
                pixels,
            },
            b: plan.b,
            units: plan.units,
            missing: plan.missing,
            nonfinite: plan.nonfinite,
        }
    }
}

/// b from all parts' bootstrap tallies: Σ_d (Σ_p c_p · b_{d,p}) / Σ_p c_p
/// (each part's b_d is a mean over its c_p samples).
pub fn pooled_b(parts: &[&PartState]) -> f64 {
    let count: f64 = parts.iter().map(|p| p.tally_count as f64).sum();
    if count == 0.0 {
        return 0.0;
    }
    let depths = parts.first().map_or(0, |p| p.depth_b.len());
    (0..depths)
        .map(|d| {
            parts
                .iter()
                .map(|p| p.tally_count as f64 * p.depth_b[d])
                .sum::<f64>()
                / count
        })
        .sum()
}

fn put_u32(out: &mut Vec<u8>, v: u32) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_u64(out: &mut Vec<u8>, v: u64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_f64(out: &mut Vec<u8>, v: f64) {
    out.extend_from_slice(&v.to_le_bytes());
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    put_u32(out, s.len() as u32);
    out.extend_from_slice(s.as_bytes());
}

/// Reads little-endian values off the front of a payload, refusing to
/// read past its end.
struct Reader<'a> {
    bytes: &'a [u8],
}

impl Reader<'_> {
    fn take<const K: usize>(&mut self) -> Result<[u8; K], String> {
        if self.bytes.len() < K {
            return Err("not a valid cmlt part state: a field runs past the end".to_string());
        }
        let (a, rest) = self.bytes.split_at(K);
        self.bytes = rest;
        Ok(a.try_into().unwrap())
    }

    fn u32(&mut self) -> Result<u32, String> {
        self.take::<4>().map(u32::from_le_bytes)
    }

    fn u64(&mut self) -> Result<u64, String> {
        self.take::<8>().map(u64::from_le_bytes)
    }

    fn f64(&mut self) -> Result<f64, String> {
        self.take::<8>().map(f64::from_le_bytes)
    }

    fn string(&mut self) -> Result<String, String> {
        let len = self.u32()? as usize;
        if len > self.bytes.len() {
            return Err("not a valid cmlt part state: a string runs past the end".to_string());
        }
        let (s, rest) = self.bytes.split_at(len);
        self.bytes = rest;
        String::from_utf8(s.to_vec())
            .map_err(|_| "not a valid cmlt part state: a string is not UTF-8".to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cmlt::math::Rgb;

    fn part(i: u32, n: u32, estimator: &str, b: f64, fill: f64) -> PartState {
        PartState {
            part: i,
            parts: n,
            frame: 0,
            width: 2,
            height: 1,
            seed: 7,
            part_seed: part_seed(7, i),
            scene_hash: 42,
            estimator: estimator.to_string(),
            settings: "s".to_string(),
            passes: 4,
            mutations: 8,
            records: 8,
            nonfinite: 0,
            b,
            tally_count: 10,
            depth_b: vec![b * 0.25, b * 0.75],
            seconds: 1.0,
            bootstrap_seconds: 0.5,
            samples: vec![[fill, 0.0, 1.0], [0.5, 0.5, 0.5]],
            splats: vec![[0.0, fill, 2.0], [0.25, 0.0, 0.125]],
        }
    }

    #[test]
    fn bytes_round_trip_and_every_corruption_is_refused() {
        let p = part(1, 3, "cmlt", 0.5, 3.0);
        let bytes = p.to_bytes();
        assert_eq!(PartState::from_bytes(&bytes, "x").unwrap(), p);
        // Every truncation, and a flipped bit anywhere.
        for len in 0..bytes.len() {
            assert!(PartState::from_bytes(&bytes[..len], "x").is_err(), "{len}");
        }
        for at in 0..bytes.len() {
            let mut b = bytes.clone();
            b[at] ^= 0x10;
            assert!(PartState::from_bytes(&b, "x").is_err(), "{at}");
        }
        let mut v2 = bytes.clone();
        v2[8] = 2;
        let e = PartState::from_bytes(&v2, "x").unwrap_err();
        assert!(e.contains("version 2"), "{e}");
    }

    #[test]
    fn part_seeds_are_distinct_and_part_zero_is_the_base_seed() {
        assert_eq!(part_seed(7, 0), 7);
        let mut seeds: Vec<u64> = (0..10_000).map(|i| part_seed(7, i)).collect();
        seeds.sort_unstable();
        seeds.dedup();
        assert_eq!(seeds.len(), 10_000);
    }

    #[test]
    fn passes_add_and_metropolis_parts_keep_their_own_b() {
        // PT: (Σ samples + Σ splats) / Σ passes.
        let (a, b) = (part(0, 2, "pt", 0.0, 1.0), part(1, 2, "pt", 0.0, 3.0));
        let m = merge(&[a, b]).unwrap();
        assert_eq!(m.image.pixels[0], Rgb::new(0.5, 0.5, 0.75));
        assert_eq!(m.units, 8);
        // MLT, equal budgets: part p enters with b_p · pixels / R, so two
        // films of equal sums and b of 1 and 3 give the mean of their
        // images, and b is pooled from the tallies (mean of 1 and 3).
        let (a, b) = (part(0, 2, "mlt", 1.0, 1.0), part(1, 2, "mlt", 3.0, 1.0));
        let m = merge(&[a.clone(), b.clone()]).unwrap();
        assert!((m.b - 2.0).abs() < 1e-12);
        let ia = a.resolve();
        let ib = b.resolve();
        for ((x, y), z) in ia.pixels.iter().zip(&ib.pixels).zip(&m.image.pixels) {
            for c in 0..3 {
                assert!(((x[c] + y[c]) * 0.5 - z[c]).abs() < 1e-6);
            }
        }
        // Unequal budgets: the image's normalisation is still the pooled b.
        let mut b2 = b.clone();
        b2.records = 24;
        b2.mutations = 24;
        b2.tally_count = 30;
        let m = merge(&[a.clone(), b2.clone()]).unwrap();
        let pooled = (10.0 * 1.0 + 30.0 * 3.0) / 40.0;
        assert!((m.b - pooled).abs() < 1e-12);
        let weighted = (8.0 * 1.0 + 24.0 * 3.0) / 32.0;
        let expect = |px: usize, c: usize| {
            let t = |p: &PartState| p.samples[px][c] + p.splats[px][c];
            (t(&a) * 1.0 + t(&b2) * 3.0) * 2.0 / 32.0 * pooled / weighted
        };
        for px in 0..2 {
            for c in 0..3 {
                assert!((m.image.pixels[px][c] as f64 - expect(px, c)).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn merging_files_one_at_a_time_equals_merging_in_memory() {
        let dir = std::env::temp_dir().join(format!("cmlt-state-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for est in ["pt", "cmlt"] {
            let mut b = part(1, 2, est, 3.0, 2.0);
            b.records = 24;
            b.tally_count = 30;
            let parts = [part(0, 2, est, 1.0, 1.0), b];
            let paths: Vec<_> = parts
                .iter()
                .map(|p| {
                    let path = dir.join(format!("{est}-{}.state", p.part));
                    p.write(&path).unwrap();
                    assert_eq!(PartState::read_header(&path).unwrap(), p.header());
                    path
                })
                .collect();
            let (a, f) = (merge(&parts).unwrap(), merge_files(&paths).unwrap());
            assert_eq!(a.image.pixels, f.image.pixels);
            assert_eq!((a.b, a.units), (f.b, f.units));
            // A file cut short is refused from its header on.
            let bytes = std::fs::read(&paths[1]).unwrap();
            std::fs::write(&paths[1], &bytes[..bytes.len() - 1]).unwrap();
            assert!(PartState::read_header(&paths[1]).is_err());
            assert!(merge_files(&paths).is_err());
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn parts_that_do_not_belong_together_are_refused() {
        let a = part(0, 2, "cmlt", 1.0, 1.0);
        let cases: Vec<(PartState, &str)> = vec![
            (
                PartState {
                    scene_hash: 43,
                    ..part(1, 2, "cmlt", 1.0, 1.0)
                },
                "scene",
            ),
            (part(1, 2, "mlt", 1.0, 1.0), "method"),
            (
                PartState {
                    settings: "t".into(),
                    ..part(1, 2, "cmlt", 1.0, 1.0)
                },
                "settings",
            ),
            (
                PartState {
                    seed: 8,
                    ..part(1, 2, "cmlt", 1.0, 1.0)
                },
                "seed",
            ),
            (part(1, 3, "cmlt", 1.0, 1.0), "part count"),
            (
                PartState {
                    frame: 1,
                    ..part(1, 2, "cmlt", 1.0, 1.0)
                },
                "frame",
            ),
            (part(0, 2, "cmlt", 2.0, 5.0), "twice"),
        ];
        for (b, what) in cases {
            let e = merge(&[a.clone(), b]).unwrap_err();
            assert!(e.contains(what), "{what}: {e}");
        }
        let mut c = part(1, 2, "cmlt", 1.0, 1.0);
        c.width = 1;
        c.samples.pop();
        c.splats.pop();
        assert!(merge(&[a.clone(), c]).unwrap_err().contains("resolution"));
        // A missing index is reported, not an error.
        assert_eq!(
            merge(&[part(1, 3, "pt", 0.0, 1.0)]).unwrap().missing,
            [0, 2]
        );
    }
}
