//! Contact between the body and a rigid indenter (Ma et al. 2005, section 2.1).

pub mod indenter;
