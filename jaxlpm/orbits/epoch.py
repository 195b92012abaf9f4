"""Epochs: the UTC date and time at which a problem's t = 0 falls (the chief's elements, or an
intercept's initial state, are osculating there). No computation depends on it (the models
have no time-dependent forces: J2 is zonal); it dates exported ephemerides (`jaxlpm.io`).

An epoch is held as a canonical ISO 8601 string, "YYYY-MM-DDTHH:MM:SS.ffffff" (UTC, naive),
a static field: a problem pytree keeps it through jit and vmap (one epoch per batch).
"""

from datetime import datetime, timezone


def utc_datetime(epoch) -> datetime:
    """`epoch` (a datetime, naive meaning UTC, or an ISO 8601 string) as a naive UTC
    datetime; ValueError otherwise."""
    if isinstance(epoch, str):
        try:
            epoch = datetime.fromisoformat(epoch)
        except ValueError:
            raise ValueError(f"epoch must be an ISO 8601 UTC date and time such as "
                             f"'2026-03-01T12:00:00' (at most 6 decimals of seconds), got "
                             f"{epoch!r}") from None
    if not isinstance(epoch, datetime):
        raise ValueError(f"epoch must be a datetime or an ISO 8601 string, got {epoch!r:.80}")
    if epoch.tzinfo is not None:
        epoch = epoch.astimezone(timezone.utc).replace(tzinfo=None)
    return epoch


def canonical_epoch(epoch):
    """None, or `epoch` as its canonical string (module docstring)."""
    return None if epoch is None else utc_datetime(epoch).isoformat(timespec="microseconds")
