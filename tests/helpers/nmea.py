"""NMEA sentences written by hand (independent of the product's writer)."""


def sentence(body: str) -> str:
    """``$<body>*<checksum>``: the checksum is the XOR of the body's bytes, two hex digits."""
    acc = 0
    for ch in body.encode():
        acc ^= ch
    return f"${body}*{acc:02X}"
