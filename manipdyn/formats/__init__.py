"""Formats: everything that crosses the disk, in and out.

Layer 2 (formats).  Model files (``modelfile``, ``modelfile_drive``, the bundled
``models/*.toml``), URDF (``urdf/``: safe XML, the link tree, the reader and
the writer), MJCF (``mjcf``: MuJoCo's model format, written), ``losses`` (what URDF and
MJCF cannot hold of a model, one account for both writers), example-robot-data (``erd``),
``load``/``save`` (``loading``,
``save``), and measurement logs as they come (``logs/``: ``read_log`` and
the table, column, time-base, filter, motor-side and ROS-bag readers under it).
May import: ``manipdyn.model`` and ``manipdyn._support``.
"""
