"""Questions about S, the set of admissible force networks of a statics problem: the exact
analysis (LPs), the projection onto S, its structure (domains, elementary clusters),
cross-sections, the elastic selection and the largest loads it carries."""
