"""Layouts: the model (:mod:`~cabinbench.layouts.model`), reading files (:mod:`~cabinbench.layouts.load`)
and the kinds they build (:mod:`~cabinbench.layouts.kinds`), generated families and versioned
suites, ROS and building maps, navigation complexity, and the one name -> layout resolver
(:func:`cabinbench.layouts.resolve.load_layout`)."""
