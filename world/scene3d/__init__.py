"""3D worlds with static geometry (Physion++-style scenes).

``types`` holds the frozen data types (static boxes, bodies, states, phases);
``motion`` the closed-form flows and exact event roots; ``rollout`` the
event-driven continuation and the contact query; ``identify`` the closed-form
fits of the latent properties (friction, restitution, mass ratio).
Nothing here imports the 2D engine; a world with only a floor is the CLEVRER
case, which keeps using ``world.rollout``.
"""
