"""CDFace (Gu, Kuriyama, Hotta: Diverse Code Query Learning for Speech-Driven Facial Animation, TVCG 2025)."""
