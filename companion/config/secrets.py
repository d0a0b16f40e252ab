"""The MAVLink 2 signing key named by the link config: read, checked, never echoed."""
from __future__ import annotations

from pathlib import Path


from companion.config.service import LinkConfig
from companion.errors import ConfigError


SIGNING_KEY_BYTES = 32


def read_signing_key(link: LinkConfig) -> bytes | None:
    """The MAVLink 2 signing key named by ``link.signing_key_file`` (None: signing off).

    The file holds 64 hex characters (whitespace ignored). Errors name the file and the problem,
    never the content: it is a secret.
    """
    if link.signing_key_file is None:
        return None
    where = f"link.signing_key_file: {link.signing_key_file}"
    try:
        text = Path(link.signing_key_file).read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{where}: cannot read: {getattr(exc, 'strerror', None) or exc}") \
            from None
    hex_text = "".join(text.split())
    if len(hex_text) != 2 * SIGNING_KEY_BYTES:
        raise ConfigError(f"{where}: expected {2 * SIGNING_KEY_BYTES} hex characters, "
                          f"got {len(hex_text)}")
    try:
        return bytes.fromhex(hex_text)
    except ValueError:
        raise ConfigError(f"{where}: not hexadecimal") from None
