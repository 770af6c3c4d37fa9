"""Adapters that cross-check forcespace against soft-particle DEM codes (LIGGGHTS, pymunk).

Depends only on the public API of forcespace; forcespace never imports this package.
"""
