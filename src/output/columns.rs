//! The per-sample columns, in one table per kind of row: each column's
//! name, unit, type, meaning and the value it holds ([`Field`]). The
//! Parquet schema and its units, the row writers of the batch bodies and
//! the column list of `docs/reference.md` all come from here, so a name and
//! its values cannot drift apart.

use crate::config::{Placement, Precision, Scene};

/// The type of a per-sample column.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The run's float type (f32 or f64; a drop's rows are f64).
    Float,
    /// A bit set or count below 256.
    U8,
    /// A bit set or count below 65,536.
    U16,
    /// True or false.
    Bool,
}

/// Which value of a sample (or of a drop's impact) a column holds: what a
/// batch body writes into it. `law` indexes the scene's laws, `plane` the
/// touching planes (contact rows) or all planes (drop rows), `axis` x, y, z
/// (w, x, y, z for the quaternion).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    /// Time since release (s).
    Time,
    /// Time since the previous impact (s).
    Interval,
    Centre(usize),
    Quaternion(usize),
    /// The orientation's Bryan angles ψ, θ, φ (degrees).
    Bryan(usize),
    Velocity(usize),
    Omega(usize),
    EnergyBefore,
    EnergyAfter {
        law: usize,
    },
    EnergyRatio {
        law: usize,
    },
    VelocityAfter {
        law: usize,
        axis: usize,
    },
    OmegaAfter {
        law: usize,
        axis: usize,
    },
    Distance {
        plane: usize,
    },
    VnBefore {
        plane: usize,
    },
    VnAfter {
        law: usize,
        plane: usize,
    },
    Impulse {
        law: usize,
        plane: usize,
    },
    TangentialImpulse {
        law: usize,
        plane: usize,
    },
    SlidingSpeed {
        law: usize,
        plane: usize,
    },
    Active {
        law: usize,
    },
    /// The sample impacts under the law: some contact approaches (and the
    /// body does not start inside a plane).
    Impacted {
        law: usize,
    },
    Flags {
        law: usize,
    },
    Sticking {
        law: usize,
    },
    FrictionFlags {
        law: usize,
    },
    Bounce,
    Planes,
}

/// Where a column is repeated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Repeat {
    /// Once per row.
    Once,
    /// Per plane, one group of columns after another (a drop's planes).
    PlaneGroup,
    /// Per law, one group of columns after another.
    LawGroup,
}

/// The indices a column template is expanded at.
#[derive(Debug, Clone, Copy, Default)]
struct Ix {
    law: usize,
    plane: usize,
    axis: usize,
}

/// One line of the table: a column template.
struct Spec {
    /// The name, with `{law}`, `{plane}` and `{axis}` where they are
    /// repeated.
    name: &'static str,
    repeat: Repeat,
    /// Per axis: the axes' names (x, y, z; w, x, y, z), in order.
    axes: &'static [&'static str],
    /// Per plane (inside a group: per touching plane).
    per_plane: bool,
    /// Only in a scene with friction.
    friction: bool,
    kind: Kind,
    unit: &'static str,
    meaning: &'static str,
    field: fn(Ix) -> Field,
}

const XYZ: &[&str] = &["x", "y", "z"];
const WXYZ: &[&str] = &["w", "x", "y", "z"];
const BRYAN: &[&str] = &["psi", "theta", "phi"];
const ONE: &[&str] = &[];

const fn spec(
    name: &'static str,
    repeat: Repeat,
    axes: &'static [&'static str],
    kind: Kind,
    unit: &'static str,
    meaning: &'static str,
    field: fn(Ix) -> Field,
) -> Spec {
    Spec {
        name,
        repeat,
        axes,
        per_plane: false,
        friction: false,
        kind,
        unit,
        meaning,
        field,
    }
}

const fn per_plane(mut s: Spec) -> Spec {
    s.per_plane = true;
    s
}

const fn with_friction(mut s: Spec) -> Spec {
    s.friction = true;
    s
}

use Kind::{Bool, Float, U16, U8};
use Repeat::{LawGroup, Once, PlaneGroup};

/// What the Bryan-angle columns hold.
const BRYAN_MEANING: &str = "the orientation as Bryan angles, A = Rx(ψ)·Ry(θ)·Rz(φ) (the scene's `bryan_deg`): ψ, φ in (−180, 180], θ in [−90, 90]; θ = ±90 is gimbal lock, where φ = 0";

/// A contact scene's row: one per sample, after `sample` (u64).
#[rustfmt::skip]
const CONTACT: &[Spec] = &[
    spec("q_{axis}", Once, WXYZ, Float, "1", "orientation drawn, unit quaternion body → world, w ≥ 0", |i| Field::Quaternion(i.axis)),
    spec("{axis}_deg", Once, BRYAN, Float, "deg", BRYAN_MEANING, |i| Field::Bryan(i.axis)),
    spec("v_{axis}", Once, XYZ, Float, "m/s", "velocity before (world)", |i| Field::Velocity(i.axis)),
    spec("omega_{axis}", Once, XYZ, Float, "rad/s", "angular velocity before (body)", |i| Field::Omega(i.axis)),
    spec("energy_before", Once, ONE, Float, "J", "kinetic energy before", |_| Field::EnergyBefore),
    per_plane(spec("vn_before_{plane}", Once, ONE, Float, "m/s", "normal velocity of the contact point before", |i| Field::VnBefore { plane: i.plane })),
    spec("energy_after_{law}", LawGroup, ONE, Float, "J", "kinetic energy after", |i| Field::EnergyAfter { law: i.law }),
    spec("energy_ratio_{law}", LawGroup, ONE, Float, "1", "energy after / energy before", |i| Field::EnergyRatio { law: i.law }),
    spec("v_after_{axis}_{law}", LawGroup, XYZ, Float, "m/s", "velocity after (world)", |i| Field::VelocityAfter { law: i.law, axis: i.axis }),
    spec("omega_after_{axis}_{law}", LawGroup, XYZ, Float, "rad/s", "angular velocity after (body)", |i| Field::OmegaAfter { law: i.law, axis: i.axis }),
    per_plane(spec("impulse_{law}_{plane}", LawGroup, ONE, Float, "N·s", "normal impulse λ", |i| Field::Impulse { law: i.law, plane: i.plane })),
    per_plane(spec("vn_after_{law}_{plane}", LawGroup, ONE, Float, "m/s", "normal velocity of the contact point after", |i| Field::VnAfter { law: i.law, plane: i.plane })),
    with_friction(per_plane(spec("tangential_impulse_{law}_{plane}", LawGroup, ONE, Float, "N·s", "|f|, the tangential impulse's magnitude", |i| Field::TangentialImpulse { law: i.law, plane: i.plane }))),
    with_friction(per_plane(spec("sliding_speed_{law}_{plane}", LawGroup, ONE, Float, "m/s", "|c⁺_t|, the contact point's sliding speed after", |i| Field::SlidingSpeed { law: i.law, plane: i.plane }))),
    spec("impacted_{law}", LawGroup, ONE, Bool, "", "some contact approached: the sample is an impact (the summary's `impacting`)", |i| Field::Impacted { law: i.law }),
    spec("active_{law}", LawGroup, ONE, U8, "", "bit i: the i-th touching plane (scene order) took an impulse", |i| Field::Active { law: i.law }),
    spec("flags_{law}", LawGroup, ONE, U16, "", "status bits 0–14: 0–2 approaching, 4–6 active, 9 energy_gain, 10 degenerate, 11 jammed, 12 unsolved, 13 penetrating, 14 recomputed by the f64 reference (8 is internal)", |i| Field::Flags { law: i.law }),
    with_friction(spec("sticking_{law}", LawGroup, ONE, U8, "", "bit i: the i-th touching plane ended sticking", |i| Field::Sticking { law: i.law })),
    with_friction(spec("friction_flags_{law}", LawGroup, ONE, U8, "", "bit 0 ambiguous, bit 1 unconverged", |i| Field::FrictionFlags { law: i.law })),
];

/// A drop scene's row: one per sample, law and impact, after `sample`
/// (u64) and `law` (string), at the moment of impact, in f64.
#[rustfmt::skip]
const DROP: &[Spec] = &[
    spec("time", Once, ONE, Float, "s", "time since release", |_| Field::Time),
    spec("interval", Once, ONE, Float, "s", "time since the previous impact (since release for the first)", |_| Field::Interval),
    spec("centre_{axis}", Once, XYZ, Float, "m", "centre (world)", |i| Field::Centre(i.axis)),
    spec("q_{axis}", Once, WXYZ, Float, "1", "orientation, unit quaternion body → world, w ≥ 0", |i| Field::Quaternion(i.axis)),
    spec("{axis}_deg", Once, BRYAN, Float, "deg", BRYAN_MEANING, |i| Field::Bryan(i.axis)),
    spec("v_{axis}", Once, XYZ, Float, "m/s", "velocity before (world)", |i| Field::Velocity(i.axis)),
    spec("omega_{axis}", Once, XYZ, Float, "rad/s", "angular velocity before (body)", |i| Field::Omega(i.axis)),
    spec("energy_before", Once, ONE, Float, "J", "kinetic energy before", |_| Field::EnergyBefore),
    spec("energy_after", Once, ONE, Float, "J", "kinetic energy after", |_| Field::EnergyAfter { law: 0 }),
    spec("energy_ratio", Once, ONE, Float, "1", "energy after / energy before", |_| Field::EnergyRatio { law: 0 }),
    spec("v_after_{axis}", Once, XYZ, Float, "m/s", "velocity after (world)", |i| Field::VelocityAfter { law: 0, axis: i.axis }),
    spec("omega_after_{axis}", Once, XYZ, Float, "rad/s", "angular velocity after (body)", |i| Field::OmegaAfter { law: 0, axis: i.axis }),
    spec("distance_{plane}", PlaneGroup, ONE, Float, "m", "the plane's signed distance to the body", |i| Field::Distance { plane: i.plane }),
    spec("vn_before_{plane}", PlaneGroup, ONE, Float, "m/s", "normal velocity of the closest point before", |i| Field::VnBefore { plane: i.plane }),
    spec("vn_after_{plane}", PlaneGroup, ONE, Float, "m/s", "normal velocity of the closest point after", |i| Field::VnAfter { law: 0, plane: i.plane }),
    spec("impulse_{plane}", PlaneGroup, ONE, Float, "N·s", "normal impulse λ", |i| Field::Impulse { law: 0, plane: i.plane }),
    spec("bounce", Once, ONE, U16, "", "the impact's number, from 1", |_| Field::Bounce),
    spec("planes", Once, ONE, U8, "", "bit i: plane i (scene order, at most six) took an impulse", |_| Field::Planes),
    spec("flags", Once, ONE, U16, "", "status bits 9 energy_gain, 10 degenerate, 11 jammed, 12 unsolved", |_| Field::Flags { law: 0 }),
];

/// One per-sample column after the keys.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub name: String,
    pub kind: Kind,
    /// The unit (`""` for bit sets and counts).
    pub unit: &'static str,
    pub field: Field,
}

/// The shape of a scene's per-sample rows, by the batch body its placement
/// chooses: at contact one row per sample with columns per law, in the
/// kernel's precision; in a drop one row per impact keyed by `sample`,
/// `law` and `bounce`, in f64.
#[derive(Debug, Clone, PartialEq)]
pub struct RowLayout {
    /// Float columns after the keys, in row order.
    pub floats: Vec<Column>,
    /// Integer columns after the floats, in row order.
    pub ints: Vec<Column>,
    /// The float columns' type.
    pub precision: Precision,
    /// Rows per law: the names the `law` key takes (empty: one row per
    /// sample).
    pub laws: Vec<String>,
}

impl RowLayout {
    /// The columns of a scene's rows, expanded from the table of its kind.
    pub fn of(scene: &Scene) -> Self {
        let friction = scene.effects().friction;
        let (table, planes, laws, precision, per_law) = match scene.placement() {
            Placement::Contact(_) => {
                let planes: Vec<String> = scene
                    .touching()
                    .iter()
                    .map(|&i| scene.planes()[i].name.clone())
                    .collect();
                let laws: Vec<String> = scene.laws().iter().map(|l| l.name()).collect();
                (CONTACT, planes, laws, scene.precision(), false)
            }
            Placement::Drop(_) => {
                let planes = scene.planes().iter().map(|p| p.name.clone()).collect();
                let laws = scene.laws().iter().map(|l| l.name()).collect();
                (DROP, planes, laws, Precision::F64, true)
            }
        };
        let specs = || table.iter().filter(|s| friction || !s.friction);
        let mut columns = Vec::new();
        let mut expand = |s: &Spec, ix: Ix, law: &str, plane: &str| {
            let axes: &[&str] = if s.axes.is_empty() { &[""] } else { s.axes };
            for (axis, a) in axes.iter().enumerate() {
                let ix = Ix { axis, ..ix };
                columns.push(Column {
                    name: s
                        .name
                        .replace("{law}", law)
                        .replace("{plane}", plane)
                        .replace("{axis}", a),
                    kind: s.kind,
                    unit: s.unit,
                    field: (s.field)(ix),
                });
            }
        };
        let per_plane =
            |s: &Spec, ix: Ix, law: &str, expand: &mut dyn FnMut(&Spec, Ix, &str, &str)| {
                if s.per_plane {
                    for (plane, p) in planes.iter().enumerate() {
                        expand(s, Ix { plane, ..ix }, law, p);
                    }
                } else {
                    expand(s, ix, law, "");
                }
            };
        for s in specs().filter(|s| s.repeat == Once) {
            per_plane(s, Ix::default(), "", &mut expand);
        }
        for (plane, p) in planes.iter().enumerate() {
            for s in specs().filter(|s| s.repeat == PlaneGroup) {
                expand(
                    s,
                    Ix {
                        plane,
                        ..Ix::default()
                    },
                    "",
                    p,
                );
            }
        }
        if !per_law {
            for (law, l) in laws.iter().enumerate() {
                for s in specs().filter(|s| s.repeat == LawGroup) {
                    per_plane(
                        s,
                        Ix {
                            law,
                            ..Ix::default()
                        },
                        l,
                        &mut expand,
                    );
                }
            }
        }
        // Integer columns follow the floats, each group in table order.
        let (floats, ints) = columns.into_iter().partition(|c| c.kind == Kind::Float);
        Self {
            floats,
            ints,
            precision,
            laws: if per_law { laws } else { Vec::new() },
        }
    }
}

/// The column list of `docs/reference.md`, as Markdown: the keys, then per
/// kind of row its table.
pub fn reference_markdown() -> String {
    let mut s = String::from(
        "Keys first: `point` (u32, sweeps) and one `sweep_PATH` column (f64) per swept field \
         with the point's value (`body.semi_axes[2]` → `sweep_body_semi_axes_2`), \
         `replicate` (u32, RQMC runs: `sample >> log2_points`), `sample` (u64), and in a \
         drop `law` (string). `LAW` is a law's name, \
         `PLANE` a plane's (at contact: the touching planes, in scene order). Floats are the \
         run's precision (a drop's are f64).\n",
    );
    for (title, table) in [
        ("Contact rows: one per sample", CONTACT),
        (
            "Drop rows: one per sample, law and impact, at the moment of impact",
            DROP,
        ),
    ] {
        s.push_str(&format!(
            "\n**{title}**\n\n| column | type | unit | meaning |\n|---|---|---|---|\n"
        ));
        for spec in table {
            let axes = match spec.axes.len() {
                0 => String::new(),
                _ => format!("{{{}}}", spec.axes.join(",")),
            };
            let name = spec
                .name
                .replace("{law}", "LAW")
                .replace("{plane}", "PLANE")
                .replace("{axis}", &axes);
            let kind = match spec.kind {
                Float => "float",
                U8 => "u8",
                U16 => "u16",
                Bool => "bool",
            };
            let unit = if spec.unit.is_empty() {
                "–"
            } else {
                spec.unit
            };
            let note = if spec.friction {
                " (with friction)"
            } else {
                ""
            };
            let meaning = spec.meaning.replace('|', "\\|");
            s.push_str(&format!(
                "| `{name}` | {kind} | {unit} | {meaning}{note} |\n"
            ));
        }
    }
    s
}
