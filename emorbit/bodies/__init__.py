"""Body kinds: each keeps its bodies' state as flat float64 arrays and calls its kernels.

- :mod:`.system`: :class:`~.system.BodySystem`, the interface every kind offers the simulation;
- :mod:`.pointmasses`: test particles (:class:`~.pointmasses.PointMasses`);
- :mod:`.rigid`: rigid bodies of mass points in director form (:class:`~.rigid.RigidBodies`);
- :mod:`.shapes`: rigid bodies discretised into mass points (box ... tetrahedral mesh);
- :mod:`.rotations`: quaternions, rotation matrices, rotation vectors, attitudes from input;
- :mod:`.elastic`: elastic bodies: meshes and materials into element arrays;
- :mod:`.coupled`: elastic bodies and what they are attached to, solved together
  (:class:`~.coupled.Structure`), with its sparse linear algebra in :mod:`.coupled_sparse`
  and its records, invariants and file datasets in :mod:`.coupled_output`.

A :class:`~emorbit.simulation.Simulation` creates a body kind's system only when a scene
adds a body of that kind, so a point-mass run never imports the rigid or elastic code.
"""
