"""The scenes shipped with forcespace (installed as ``forcespace.scenes``): TOML files
read by :func:`forcespace.load_scene` by name, e.g. ``load_scene("paper")``."""
