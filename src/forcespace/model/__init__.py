"""The nouns of forcespace and their invariants: scenes, walls, packings, statics problems."""
