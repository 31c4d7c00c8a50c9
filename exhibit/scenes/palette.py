"""The exhibit's named colours, chosen so that every visitor tells apart the ones that mean
different things: every pair the scenes use together stays at least ΔE 15 (CAM02-UCS) apart
under protanopia, deuteranopia and tritanopia, lit surfaces at full and half light, and against
the dark background (exhibit.scenes.colours checks it; docs/RENDERING.md shows before and
after). The names are what the captions call them: a bluish green and a vermillion stay "green"
and "red" to every eye (the Okabe-Ito families), where the old pure green and red were one
colour to a protanope (ΔE 6.8) and the magenta and blue fibres too (ΔE 5.3)."""

GREEN = (0.0, 0.74, 0.57)  # the green doughnut (Figures 6-8)
GREY = (0.92, 0.92, 0.92)  # the neutral doughnut between them
RED = (0.78, 0.14, 0.02)  # the red doughnut, the offset curves, the x axis
PURPLE = (0.69, 0.36, 0.70)  # a Hopf fibre (was magenta)
BLUE = (0.05, 0.13, 0.72)  # the other fibre, silhouettes, the w axis
AMBER = (0.9, 0.76, 0.19)  # the y axis
# the z axis: light, and apart from everything in Figures 6-8 in every vision (ΔE 18 at least);
# the mint it was, (0.11, 0.88, 0.61), was ΔE 10.8 from the green doughnut under tritanopia
LAVENDER = (0.7, 0.7, 0.95)
WIRE = (0.3, 0.85, 0.75)  # the collision's pipe, a wire frame
ORANGE = (0.85, 0.55, 0.25)  # the collision surface
SKY = (0.55, 0.7, 0.9)  # the offset pipes
YELLOW = (0.95, 0.8, 0.1)  # singular points
TEAL = (0.35, 0.75, 0.75)  # the complex square
