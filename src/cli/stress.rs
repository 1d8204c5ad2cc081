//! `impactmc stress`: the hard-case families and their error bounds.

use super::{emit, Failure};

pub fn run(samples: usize) -> Result<(), Failure> {
    let rows = impactmc::stress::run(samples);
    emit(&impactmc::stress::table(&rows));
    let bad = rows.iter().filter(|r| !r.within_bound()).count();
    emit(&format!(
        "\n{} rows, {} beyond their bound; matrix → Bryan → matrix worst error near θ = ±90°: {:.1e}\n",
        rows.len(),
        bad,
        impactmc::stress::gimbal_round_trip_error()
    ));
    if bad > 0 {
        return Err(Failure::failed(format!(
            "{bad} stress rows beyond their bound"
        )));
    }
    Ok(())
}
