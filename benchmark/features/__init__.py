"""Feature extractors over coefficient windows (the BlendVOCA VAE)."""

from benchmark.features.vae import CoeffsVAE, encode_windows, load_published_vae, load_vae_state

__all__ = ["CoeffsVAE", "encode_windows", "load_published_vae", "load_vae_state"]
