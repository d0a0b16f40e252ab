"""MAVLink on the wire: the codecs (events and intents), the asyncio link with signing, tlogs."""
