//! Validation of a raw scene, section by section: each check names the
//! field path and the offending value; [`Scene::validate`] adds the file
//! and line.

use glam::DVec3;

use crate::config::bad::{bad, Bad};
use crate::config::effects::Effects;
use crate::config::plane::NamedPlane;
use crate::config::scene::{
    Contact, DropBox, OrientationDist, Placement, Precision, Sampling, Scene, Target, VectorDist,
    DEFAULT_TOLERANCE_RELATIVE, MAX_LOG2_POINTS, MAX_SAMPLES,
};
use crate::config::{RawOrientation, RawScene, RawVector};
use crate::physics::{matrix_from_bryan, Bryan, Ellipsoid, Law, Plane, SymMatrix};

fn finite3(path: &[&str], v: [f64; 3]) -> Result<DVec3, Bad> {
    if v.iter().all(|x| x.is_finite()) {
        Ok(DVec3::from_array(v))
    } else {
        Err(bad(path, format!("must be finite, got {v:?}")))
    }
}

/// Parses `paper`, `newton`, `poisson`, `stronge`, `pgsN`.
pub fn parse_law(s: &str) -> Option<Law> {
    match s {
        "paper" => Some(Law::Paper),
        "newton" => Some(Law::Newton),
        "poisson" => Some(Law::Poisson),
        "stronge" => Some(Law::Stronge),
        _ => {
            let n: u32 = s.strip_prefix("pgs")?.parse().ok()?;
            (n >= 1).then_some(Law::Pgs { sweeps: n })
        }
    }
}

fn vector_dist(field: &str, raw: &RawVector) -> Result<VectorDist, Bad> {
    Ok(match *raw {
        RawVector::Normal { mean, sd } => {
            let mean = finite3(&[field, "mean"], mean)?;
            let sd_v = finite3(&[field, "sd"], sd)?;
            if sd_v.min_element() < 0.0 {
                return Err(bad(&[field, "sd"], format!("must be ≥ 0, got {sd:?}")));
            }
            VectorDist::Normal { mean, sd: sd_v }
        }
        RawVector::Uniform { low, high } => {
            let l = finite3(&[field, "low"], low)?;
            let h = finite3(&[field, "high"], high)?;
            if (0..3).any(|i| l[i] > h[i]) {
                return Err(bad(
                    &[field, "high"],
                    format!("must be ≥ low {low:?}, got {high:?}"),
                ));
            }
            VectorDist::Uniform { low: l, high: h }
        }
        RawVector::Fixed { value } => VectorDist::Fixed(finite3(&[field, "value"], value)?),
    })
}

/// `laws`: known, and each once.
fn laws(raw: &RawScene) -> Result<Vec<Law>, Bad> {
    if raw.laws.is_empty() {
        return Err(bad(&["laws"], "must list at least one law"));
    }
    let mut laws = Vec::new();
    for (i, s) in raw.laws.iter().enumerate() {
        let idx = i.to_string();
        let law = parse_law(s).ok_or_else(|| {
            bad(
                &["laws", &idx],
                format!(
                    "unknown law {s:?}; expected paper, newton, poisson, stronge or pgsN (N ≥ 1)"
                ),
            )
        })?;
        if laws.contains(&law) {
            return Err(bad(&["laws", &idx], format!("law {s:?} is listed twice")));
        }
        laws.push(law);
    }
    Ok(laws)
}

/// `[body]`.
fn body(raw: &RawScene) -> Result<Ellipsoid, Bad> {
    Ellipsoid::new(raw.body.semi_axes, raw.body.mass).map_err(|e| match e {
        crate::physics::BodyError::SemiAxis { .. } => bad(&["body", "semi_axes"], e.to_string()),
        crate::physics::BodyError::Mass(_) => bad(&["body", "mass"], e.to_string()),
    })
}

/// `[[planes]]`: valid planes with unique names.
fn planes(raw: &RawScene) -> Result<Vec<NamedPlane>, Bad> {
    if raw.planes.is_empty() {
        return Err(bad(&["planes"], "a scene needs at least one plane"));
    }
    let mut planes: Vec<NamedPlane> = Vec::new();
    for (i, p) in raw.planes.iter().enumerate() {
        let idx = i.to_string();
        let plane = Plane::new(p.normal, p.offset, p.restitution)
            .and_then(|q| q.with_friction(p.friction.unwrap_or(0.0)))
            .map_err(|e| bad(&["planes", &idx, e.field()], e.to_string()))?;
        if p.name.is_empty() || p.name.contains('+') {
            return Err(bad(
                &["planes", &idx, "name"],
                format!("must be non-empty without '+', got {:?}", p.name),
            ));
        }
        if planes.iter().any(|q| q.name == p.name) {
            return Err(bad(
                &["planes", &idx, "name"],
                format!("plane name {:?} is used twice", p.name),
            ));
        }
        planes.push(NamedPlane {
            name: p.name.clone(),
            plane,
        });
    }
    Ok(planes)
}

use crate::physics::MAX_DROP_PLANES;

/// `placement.drop`: a box of start positions from which the body cannot
/// touch any plane, whatever its orientation.
fn drop_box(
    raw: &RawScene,
    body: &Ellipsoid,
    planes: &[NamedPlane],
) -> Result<Option<DropBox>, Bad> {
    Ok(match &raw.placement.drop {
        None => None,
        Some(d) => {
            if !raw.placement.touching.is_empty() {
                return Err(bad(
                    &["placement"],
                    format!(
                        "give either touching or drop, not both (touching = {:?})",
                        raw.placement.touching
                    ),
                ));
            }
            if planes.len() > MAX_DROP_PLANES {
                return Err(bad(
                    &["planes"],
                    format!(
                        "a drop scene has at most {MAX_DROP_PLANES} planes (statistics are kept per set of planes hit), got {}",
                        planes.len()
                    ),
                ));
            }
            let lo = finite3(&["placement", "drop", "min"], d.min)?;
            let hi = finite3(&["placement", "drop", "max"], d.max)?;
            if lo.cmpgt(hi).any() {
                return Err(bad(
                    &["placement", "drop"],
                    format!(
                        "min must be ≤ max componentwise, got min {:?}, max {:?}",
                        d.min, d.max
                    ),
                ));
            }
            // Every start must be clear of every plane whatever the
            // orientation: the body fits in a ball of its largest semi-axis.
            let reach = body.length_scale();
            for p in planes {
                let n = p.plane.normal();
                let corner = DVec3::select(n.cmpge(DVec3::ZERO), lo, hi);
                let d = p.plane.signed_distance(corner);
                if !(d > reach) {
                    return Err(bad(
                        &["placement", "drop"],
                        format!(
                            "impossible placement: the drop box comes within {d} m of plane {:?} (its corner {:?}), but the body reaches {reach} m from its centre; raw value min {:?}, max {:?}",
                            p.name,
                            corner.to_array(),
                            lo.to_array(),
                            hi.to_array()
                        ),
                    ));
                }
            }
            Some(DropBox { low: lo, high: hi })
        }
    })
}

/// `[orientation]`.
fn orientation(raw: &RawScene) -> Result<OrientationDist, Bad> {
    Ok(match raw.orientation {
        RawOrientation::Uniform => OrientationDist::Uniform,
        RawOrientation::Fixed { bryan_deg } => {
            let d = finite3(&["orientation", "bryan_deg"], bryan_deg)?;
            OrientationDist::Fixed(matrix_from_bryan(Bryan {
                psi: d.x.to_radians(),
                theta: d.y.to_radians(),
                phi: d.z.to_radians(),
            }))
        }
        RawOrientation::BryanUniform {
            psi_deg,
            theta_deg,
            phi_deg,
        } => {
            let mut low = DVec3::ZERO;
            let mut high = DVec3::ZERO;
            for (i, (name, r)) in [
                ("psi_deg", psi_deg),
                ("theta_deg", theta_deg),
                ("phi_deg", phi_deg),
            ]
            .into_iter()
            .enumerate()
            {
                if !(r[0].is_finite() && r[1].is_finite() && r[0] <= r[1]) {
                    return Err(bad(
                        &["orientation", name],
                        format!("must be a finite [low, high] with low ≤ high, got {r:?}"),
                    ));
                }
                low[i] = r[0].to_radians();
                high[i] = r[1].to_radians();
            }
            OrientationDist::BryanUniform { low, high }
        }
    })
}

/// `sampling` and `replicates`: RQMC runs `replicates` scrambles of the
/// smallest power of two of points that makes at least `samples` in all
/// (at most 2³² per replicate).
fn sampling(raw: &RawScene) -> Result<Sampling, Bad> {
    const MAX_REPLICATES: u64 = 1 << 20;
    match raw.sampling.as_deref().unwrap_or("mc") {
        "mc" => match raw.replicates {
            None => Ok(Sampling::Mc),
            Some(r) => Err(bad(
                &["replicates"],
                format!("is for sampling = \"rqmc\" only (sampling is \"mc\"), got {r}"),
            )),
        },
        "rqmc" => {
            let replicates = raw.replicates.unwrap_or(Sampling::DEFAULT_REPLICATES);
            if !(2..=MAX_REPLICATES).contains(&replicates) {
                return Err(bad(
                    &["replicates"],
                    format!("must be in 2..=2^20 (intervals come from the replicates' spread), got {replicates}"),
                ));
            }
            if raw.samples < replicates {
                return Err(bad(
                    &["samples"],
                    format!("must be at least replicates ({replicates}) with sampling = \"rqmc\", got {}", raw.samples),
                ));
            }
            let per = raw.samples.div_ceil(replicates).next_power_of_two();
            let log2_points = per.trailing_zeros();
            if log2_points > MAX_LOG2_POINTS
                || (replicates as u128) << log2_points > MAX_SAMPLES as u128
            {
                return Err(bad(
                    &["samples"],
                    format!(
                        "is too large for sampling = \"rqmc\": {replicates} replicates of 2^{log2_points} points (at most 2^32 points each, 2^53 in all), got {}",
                        raw.samples
                    ),
                ));
            }
            Ok(Sampling::Rqmc {
                replicates,
                log2_points,
            })
        }
        other => Err(bad(
            &["sampling"],
            format!("must be \"mc\" or \"rqmc\", got {other:?}"),
        )),
    }
}

/// `[target]`: positive half-widths, and a sample budget of at least
/// `samples` (default: 2^32, or `samples` if more).
fn target(raw: &RawScene) -> Result<Option<Target>, Bad> {
    let Some(t) = &raw.target else {
        return Ok(None);
    };
    if t.ci95.is_empty() {
        return Err(bad(
            &["target", "ci95"],
            "names no statistic: give at least one, e.g. energy_ratio = 1e-4",
        ));
    }
    for (name, &eps) in &t.ci95 {
        if !(eps.is_finite() && eps > 0.0) {
            return Err(bad(
                &["target", "ci95", name],
                format!("must be a finite half-width > 0, got {eps}"),
            ));
        }
    }
    let max_samples = t.max_samples.unwrap_or((1u64 << 32).max(raw.samples));
    if !(raw.samples..=MAX_SAMPLES).contains(&max_samples) {
        return Err(bad(
            &["target", "max_samples"],
            format!(
                "must be in samples..=2^53 ({}..=2^53), got {max_samples}",
                raw.samples
            ),
        ));
    }
    Ok(Some(Target {
        ci95: t.ci95.iter().map(|(k, &v)| (k.clone(), v)).collect(),
        max_samples,
    }))
}

impl Scene {
    /// Raw → validated, section by section; every default made explicit.
    pub(super) fn from_raw(raw: RawScene) -> Result<Self, Bad> {
        if raw.name.trim().is_empty() || raw.name.contains(['/', '\\']) {
            return Err(bad(
                &["name"],
                format!(
                    "must be a non-empty name without slashes, got {:?}",
                    raw.name
                ),
            ));
        }
        if !(1..=MAX_SAMPLES).contains(&raw.samples) {
            return Err(bad(
                &["samples"],
                format!("must be in 1..=2^53, got {}", raw.samples),
            ));
        }
        let laws = laws(&raw)?;
        let precision: Precision = raw.precision.parse().map_err(|m| bad(&["precision"], m))?;
        let sampling = sampling(&raw)?;
        let target = target(&raw)?;
        // A drop sample costs hundreds of contact samples: smaller batches
        // keep every core busy on a drop scene's default sample count.
        let default_batch = if raw.placement.drop.is_some() {
            4096
        } else {
            65536
        };
        let batch_size = raw.batch_size.unwrap_or(default_batch);
        if !(batch_size.is_power_of_two() && (256..=1 << 22).contains(&batch_size)) {
            return Err(bad(
                &["batch_size"],
                format!("must be a power of two in 256..=4194304, got {batch_size}"),
            ));
        }
        let body = body(&raw)?;
        let planes = planes(&raw)?;
        let drop = drop_box(&raw, &body, &planes)?;
        let placement = match drop {
            Some(b) => Placement::Drop(b),
            None => {
                let touching = Self::resolve_touching(&raw, &planes)?;
                let offsets = Self::solve_placement(&raw, &planes, &touching)?;
                Placement::Contact(Contact { touching, offsets })
            }
        };
        let touching: &[usize] = match &placement {
            Placement::Contact(c) => &c.touching,
            Placement::Drop(_) => &[],
        };
        let length_scale = planes
            .iter()
            .map(|p| p.plane.offset().abs())
            .fold(body.length_scale(), f64::max);
        let tight = DEFAULT_TOLERANCE_RELATIVE * length_scale;
        let tolerance = match raw.contact_tolerance {
            None => tight,
            Some(t) if t.is_finite() && t >= 0.0 => t,
            Some(t) => {
                return Err(bad(
                    &["contact_tolerance"],
                    format!("must be a finite number ≥ 0 (metres), got {t}"),
                ))
            }
        };
        let orientation = orientation(&raw)?;
        let effects = Effects::derive(
            &raw,
            &body,
            &planes,
            touching,
            drop.is_some(),
            (tolerance, tight),
        )?;
        Self::check_laws_with_friction(&laws, &planes, touching, drop.is_some())?;
        let velocity = vector_dist("velocity", &raw.velocity)?;
        let angular_velocity = vector_dist("angular_velocity", &raw.angular_velocity)?;
        Self::check_ranges(&body, precision, velocity, angular_velocity, length_scale)?;
        // RQMC runs whole replicates, each whole batches: a replicate
        // smaller than a batch is its own batch.
        let (samples, batch_size) = match sampling {
            Sampling::Mc => (raw.samples, batch_size),
            Sampling::Rqmc {
                replicates,
                log2_points,
            } => (replicates << log2_points, batch_size.min(1 << log2_points)),
        };
        // Every default made explicit, for the manifest.
        let mut raw = raw;
        raw.contact_tolerance = Some(tolerance);
        raw.batch_size = Some(batch_size);
        raw.samples = samples;
        raw.sampling = Some(sampling.name().into());
        raw.replicates = sampling.replicates();
        Ok(Scene {
            name: raw.name.clone(),
            samples,
            seed: raw.seed,
            laws,
            precision,
            sampling,
            tolerance,
            batch_size,
            body,
            planes,
            placement,
            effects,
            orientation,
            velocity,
            angular_velocity,
            target,
            raw,
        })
    }

    /// The laws a scene's planes allow (friction.md): `poisson` is not
    /// defined with friction on a plane that can take an impact; `stronge`
    /// takes one touching plane. In a drop scene `stronge` solves impacts
    /// on one plane, and one that meets several planes at once is solved by
    /// `newton` and counted as `coupled_fallback`.
    fn check_laws_with_friction(
        laws: &[Law],
        planes: &[NamedPlane],
        touching: &[usize],
        drop: bool,
    ) -> Result<(), Bad> {
        let position = |law: Law| laws.iter().position(|&l| l == law).unwrap_or(0).to_string();
        let impacting: Vec<usize> = if drop {
            (0..planes.len()).collect()
        } else {
            touching.to_vec()
        };
        if laws.contains(&Law::Poisson) {
            if let Some(&i) = impacting
                .iter()
                .find(|&&i| planes[i].plane.friction() > 0.0)
            {
                // Offer only the laws this scene takes: stronge needs one
                // touching plane at contact.
                let alternatives = if drop || touching.len() == 1 {
                    "newton, paper, pgsN or stronge"
                } else {
                    "newton, paper or pgsN"
                };
                return Err(bad(
                    &["laws", &position(Law::Poisson)],
                    format!(
                        "law poisson is not defined with friction, and plane {:?} has friction {}; use {alternatives}",
                        planes[i].name,
                        planes[i].plane.friction()
                    ),
                ));
            }
        }
        if laws.contains(&Law::Stronge) {
            let at = position(Law::Stronge);
            if !drop && touching.len() > 1 {
                let names: Vec<&str> = touching.iter().map(|&i| planes[i].name.as_str()).collect();
                return Err(bad(
                    &["laws", &at],
                    format!("law stronge takes one touching plane; the placement touches planes {names:?}"),
                ));
            }
        }
        Ok(())
    }

    /// Refuses scenes whose quantities overflow or underflow the kernel's
    /// float type: every derived constant (m, 1/m, J, 1/J, a², lengths) and a
    /// generous kinetic-energy scale must be normal numbers, with three
    /// decades of headroom for f32.
    fn check_ranges(
        body: &Ellipsoid,
        precision: Precision,
        velocity: VectorDist,
        omega: VectorDist,
        length_scale: f64,
    ) -> Result<(), Bad> {
        let (lo, hi, kind) = match precision {
            Precision::F32 => (
                f32::MIN_POSITIVE as f64 * 1e3,
                f32::MAX as f64 * 1e-3,
                "the f32 kernel",
            ),
            Precision::F64 => (f64::MIN_POSITIVE * 1e3, f64::MAX * 1e-3, "f64"),
        };
        let j = body.inertia();
        let a = body.semi_axes();
        let constants = [
            body.mass(),
            1.0 / body.mass(),
            j.min_element(),
            j.max_element(),
            1.0 / j.min_element(),
            a.min_element() * a.min_element(),
            a.max_element() * a.max_element(),
            length_scale,
        ];
        if constants.iter().any(|&x| !(x >= lo && x <= hi)) {
            return Err(bad(
                &["body"],
                format!(
                    "mass {} kg and semi-axes {:?} m give quantities beyond the range of {kind} (inertia {:?} kg·m², length scale {length_scale:e} m); use precision = \"f64\" or rescale the units",
                    body.mass(),
                    a.to_array(),
                    j.to_array()
                ),
            ));
        }
        let reach = |d: VectorDist| match d {
            VectorDist::Normal { mean, sd } => mean.abs().max_element() + 40.0 * sd.max_element(),
            VectorDist::Uniform { low, high } => low.abs().max(high.abs()).max_element(),
            VectorDist::Fixed(v) => v.abs().max_element(),
        };
        let (v, w) = (reach(velocity), reach(omega));
        let energy = 0.5 * body.mass() * 3.0 * v * v + 0.5 * j.max_element() * 3.0 * w * w;
        let scale = v + a.max_element() * w;
        if !(energy <= hi && scale <= hi.sqrt()) {
            let field = if 0.5 * body.mass() * 3.0 * v * v > 0.5 * j.max_element() * 3.0 * w * w {
                "velocity"
            } else {
                "angular_velocity"
            };
            return Err(bad(
                &[field],
                format!("speeds up to {v:e} m/s and {w:e} rad/s give kinetic energies up to {energy:e} J, beyond the range of {kind}"),
            ));
        }
        Ok(())
    }

    fn resolve_touching(raw: &RawScene, planes: &[NamedPlane]) -> Result<Vec<usize>, Bad> {
        let names = &raw.placement.touching;
        if names.is_empty() || names.len() > 3 {
            return Err(bad(
                &["placement", "touching"],
                format!("impossible placement: the body can touch 1 to 3 planes with independent normals, got {} ({names:?})", names.len()),
            ));
        }
        let mut idx = Vec::new();
        for (i, n) in names.iter().enumerate() {
            let j = planes.iter().position(|p| &p.name == n).ok_or_else(|| {
                bad(
                    &["placement", "touching", &i.to_string()],
                    format!("no plane is named {n:?}"),
                )
            })?;
            if idx.contains(&j) {
                return Err(bad(
                    &["placement", "touching", &i.to_string()],
                    format!("plane {n:?} is listed twice"),
                ));
            }
            idx.push(j);
        }
        // Scene order, so that active-set names read in scene order.
        idx.sort_unstable();
        Ok(idx)
    }

    /// The minimal-norm centre making the touching planes touch:
    /// `X0 = Nᵀ (N Nᵀ)⁻¹ (h − e)` with N the touching normals as rows.
    fn solve_placement(
        raw: &RawScene,
        planes: &[NamedPlane],
        touching: &[usize],
    ) -> Result<Vec<DVec3>, Bad> {
        let normals: Vec<DVec3> = touching.iter().map(|&i| planes[i].plane.normal()).collect();
        let n = normals.len();
        let mut gram = SymMatrix::zeros(n);
        for i in 0..n {
            for j in 0..n {
                gram.set(i, j, normals[i].dot(normals[j]));
            }
        }
        let min_eig = crate::physics::smallest_eigenvalue_scaled(&gram);
        if !(min_eig > 1e-10) {
            let names: Vec<&str> = touching.iter().map(|&i| planes[i].name.as_str()).collect();
            return Err(bad(
                &["placement", "touching"],
                format!(
                    "impossible placement: the normals of {names:?} are (nearly) dependent (smallest eigenvalue of their Gram matrix {min_eig:e}), so no centre touches them all at once; raw value {:?}",
                    raw.placement.touching
                ),
            ));
        }
        // Columns of Nᵀ (N Nᵀ)⁻¹: solve the Gram system per unit vector.
        let mut cols = Vec::new();
        for i in 0..n {
            let mut e = vec![0.0; n];
            e[i] = 1.0;
            let x = gram
                .solve_spd(&e, 0.0)
                .expect("Gram matrix checked regular");
            cols.push((0..n).map(|j| normals[j] * x[j]).sum::<DVec3>());
        }
        Ok(cols)
    }
}
