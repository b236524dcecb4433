"""The position sensor of a preset: ``[sensor]`` (noise, bandwidth, delay), checked and written.

The sensor belongs to the hardware, like the amplifier's ``[amplifier]``
table (:mod:`hammerstein.models.amplifier`), so a preset can carry it and
every feedback scenario on that preset uses it unless its own
``[feedback] sensor`` overrides a key::

    [sensor]
    noise_nm = 40.0          # white noise added to the position, RMS per output [nm]
    bandwidth_hz = 5000.0    # first-order low-pass of the sensor's electronics [Hz]
    delay = 1                # samples between the position and its reading

The loop's equations are those of
:class:`hammerstein.compensation.feedback.Sensor` (docs/feedback.md). The
same checks serve the preset's table and the scenario's ``[feedback]
sensor``: every problem is reported at once, each naming its key.
"""

from __future__ import annotations

import math

from hammerstein.exceptions import PresetError

__all__ = ["SENSOR_KEYS", "check_sensor_table", "sensor_from_table", "sensor_to_table"]

#: keys of a sensor table and their units
SENSOR_KEYS = {"noise_nm": "nm RMS", "bandwidth_hz": "Hz", "delay": "samples"}
#: the largest sensor delay accepted [samples]
MAX_DELAY = 1000


def _finite(v):
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def check_sensor_table(table, where, problems):
    """Check a sensor table, appending one ``where.key: message`` line per problem.

    Parameters
    ----------
    table : object
        The parsed table (``[sensor]`` of a preset, ``sensor`` of a
        ``[feedback]`` table).
    where : str
        Prefix of the messages (e.g. ``"preset.toml: sensor"``).
    problems : list of str
        Receives the problems (every one, not only the first).

    Returns
    -------
    dict
        The keys given, numbers as float (``delay`` as int); meaningful when
        no problem was added.

    Examples
    --------
    >>> problems = []
    >>> check_sensor_table({"noise_nm": -1, "delay": 0.5, "colour": 1}, "s", problems)
    {'noise_nm': -1, 'delay': 0.5}
    >>> len(problems)
    3
    """
    if not isinstance(table, dict):
        problems.append(f"{where}: expected a table (noise_nm, bandwidth_hz, delay), found "
                        f"{table!r}")
        return {}
    for k in sorted(set(table) - set(SENSOR_KEYS)):
        problems.append(f"{where}.{k}: unknown key (expected {', '.join(SENSOR_KEYS)})")
    out = {k: table[k] for k in SENSOR_KEYS if k in table}
    n = table.get("noise_nm", 0.0)
    if not (_finite(n) and n >= 0):
        problems.append(f"{where}.noise_nm: expected a number >= 0 [nm RMS], found {n!r}")
    elif "noise_nm" in out:
        out["noise_nm"] = float(n)
    if "bandwidth_hz" in table:
        b = table["bandwidth_hz"]
        if not (_finite(b) and b > 0):
            problems.append(f"{where}.bandwidth_hz: expected a positive frequency [Hz], found "
                            f"{b!r}")
        else:
            out["bandwidth_hz"] = float(b)
    d = table.get("delay", 0)
    if not (isinstance(d, int) and not isinstance(d, bool) and 0 <= d <= MAX_DELAY):
        problems.append(f"{where}.delay: expected an integer 0..{MAX_DELAY} [samples], found "
                        f"{d!r}")
    return out


def sensor_from_table(table, source="preset"):
    """The checked ``[sensor]`` table of a preset, or None without one.

    Parameters
    ----------
    table : dict or None
        The parsed ``[sensor]`` table.
    source : str
        The file, for the message.

    Returns
    -------
    dict or None
        ``noise_nm`` [nm RMS], ``bandwidth_hz`` [Hz], ``delay`` [samples],
        the keys given.

    Raises
    ------
    PresetError
        Listing every problem of the table, each naming its key
        (``<source>: sensor.noise_nm: expected ...``).
    """
    if table is None:
        return None
    problems = []
    out = check_sensor_table(table, "sensor", problems)
    if problems:
        raise PresetError(f"{source}: " + "; ".join(problems))
    return out


def sensor_to_table(sensor):
    """A sensor as the ``[sensor]`` table a preset file holds (the inverse of the above).

    Parameters
    ----------
    sensor : dict
        ``noise_nm``, ``bandwidth_hz`` (None or absent for no low-pass),
        ``delay``.

    Returns
    -------
    dict
        TOML-ready: ``sensor_from_table(sensor_to_table(s)) == sensor_to_table(s)``.

    Raises
    ------
    PresetError
        When the values are not a valid sensor (every problem listed).
    """
    table = {k: v for k, v in dict(sensor).items() if v is not None}
    problems = []
    out = check_sensor_table(table, "sensor", problems)
    if problems:
        raise PresetError("; ".join(problems))
    return out
