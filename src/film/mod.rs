//! Film: accumulation and image output.
