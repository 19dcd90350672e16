"""Rendering techniques of seeds 001 and 003: the forward renderer that draws a frame,
many-light shading, image warping and compositing (image-based rendering), and render-state
sorting. They draw what the culling decided; they never decide visibility themselves.
"""
