//! The acoustic robot of the paper's experiments (§VI): placeholder filled in
//! by the acoustic work package.
