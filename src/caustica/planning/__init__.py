"""How ``auto`` plans a scene: ``rules`` (the technique and parameters for each part of the scene, with the
reasons) and ``probes`` (what exact rays say of the scene that the rules weigh).
"""
