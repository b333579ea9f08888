//! Parsing a fault vector from the command line: `K1,K2,…,K9`, each in [0, 1]; the paper's
//! eight `K1,…,K8` read with no demagnetization (k9 = 0).

use shared::fault::{FaultVectorError, FAULT_COUNT, FAULT_NAMES, PAPER_FAULT_COUNT};
use shared::FaultVector;

/// Parses nine comma-separated numbers in [0, 1], or the paper's eight (demagnetization 0);
/// the error names the offending value.
pub fn parse_fault_vector(text: &str) -> Result<FaultVector, String> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != FAULT_COUNT && parts.len() != PAPER_FAULT_COUNT {
        return Err(format!(
            "expected {FAULT_COUNT} comma-separated values ({}), or the paper's first \
             {PAPER_FAULT_COUNT} (no demagnetization), got {}",
            FAULT_NAMES.join(","),
            parts.len()
        ));
    }
    let mut k = *FaultVector::NOMINAL.as_array();
    for (i, part) in parts.iter().enumerate() {
        k[i] = part.parse::<f32>().map_err(|_| {
            format!(
                "value {} ({}) is not a number: {part:?}",
                i + 1,
                FAULT_NAMES[i]
            )
        })?;
    }
    FaultVector::new(k).map_err(|e| match e {
        FaultVectorError::NotFinite { index } | FaultVectorError::OutOfRange { index } => {
            let i = usize::from(index);
            format!(
                "value {} ({}) = {} is outside [0, 1]",
                i + 1,
                FAULT_NAMES[i],
                parts[i]
            )
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn accepts_nine_values_or_the_papers_eight_in_range() {
        let k = parse_fault_vector("0.1, 0, 0.2,0,0,0.5,0.5,1").unwrap();
        assert_eq!(k.as_array(), &[0.1, 0.0, 0.2, 0.0, 0.0, 0.5, 0.5, 1.0, 0.0]);
        let k = parse_fault_vector("0.1, 0, 0.2,0,0,0.5,0.5,1,0.3").unwrap();
        assert_eq!(k.as_array(), &[0.1, 0.0, 0.2, 0.0, 0.0, 0.5, 0.5, 1.0, 0.3]);
        let e = parse_fault_vector("0,0,0,0,0,0,0.5,0.5,2").unwrap_err();
        assert!(e.contains("value 9 (demagnetization)"), "{e}");
    }

    #[test]
    fn errors_name_the_problem() {
        assert!(parse_fault_vector("0.1,0.2")
            .unwrap_err()
            .contains("expected 9"));
        let e = parse_fault_vector("0,0,0,x,0,0,0.5,0.5").unwrap_err();
        assert!(
            e.contains("value 4") && e.contains("short_b") && e.contains("\"x\""),
            "{e}"
        );
        let e = parse_fault_vector("0,1.5,0,0,0,0,0.5,0.5").unwrap_err();
        assert!(
            e.contains("value 2") && e.contains("backlash") && e.contains("1.5"),
            "{e}"
        );
        let e = parse_fault_vector("0,0,0,0,0,0,0.5,NaN").unwrap_err();
        assert!(e.contains("value 8"), "{e}");
    }
}
