"""Tool-specific annotations that major SSP importers need to load a system.

SSP 1.0 lets any tool store its own data in an ``ssc:Annotation`` of a named type, and
tells every other tool to ignore types it does not know: adding one costs the others
nothing. pendfmu writes the ones measured to be needed (TOOL-NOTES.md):

- OMSimulator refuses a system without its ``org.openmodelica`` annotation naming the
  system type (``[NewSystem] internal error``, then an abort). The form is the one
  OMSimulator's own SSP export writes into ``ssd:System/ssd:Annotations``, quoted from its
  test suite (OpenModelica/OMSimulator, testsuite/simulation/import_export_snapshot.lua,
  the expected SystemStructure.ssd of a weakly coupled system ``oms_system_wc``)::

      <ssc:Annotation type="org.openmodelica">
        <oms:Annotations>
          <oms:SimulationInformation>
            <oms:FixedStepMaster description="oms-ma" stepSize="0.001000"
                absoluteTolerance="0.000100" relativeTolerance="0.000100" />
          </oms:SimulationInformation>
        </oms:Annotations>
      </ssc:Annotation>

  "oms-ma" is OMSimulator's fixed-step master of a weakly coupled (co-simulation)
  system, the kind of system the rig is. OMSimulator reads the file with a parser that
  matches the literal prefix, so the prefix is ``oms`` as in its export.

ecos and libcosim need no annotation: they read the components, connections and
parameter bindings and ignore annotations (and libcosim's ``com.opensimulationplatform``
step-size annotation is optional; the step is given on the command line).
"""

from __future__ import annotations

from lxml import etree

from pendfmu.ssp._xml import format_double, ssc

OMS_NS = "https://raw.githubusercontent.com/OpenModelica/OMSimulator/master/schema/oms.xsd"
OMS_ANNOTATION_TYPE = "org.openmodelica"
OMS_FIXED_STEP_MASTER = "oms-ma"
# OMSimulator's own defaults (its export above), used where the system states no step.
OMS_DEFAULT_STEP = 1e-3
OMS_TOLERANCE = 1e-4


def oms(tag: str) -> str:
    """Qualified name of an element of OMSimulator's annotation namespace."""
    return f"{{{OMS_NS}}}{tag}"


def omsimulator_annotation(step_size: float | None) -> etree._Element:
    """The ssc:Annotation that tells OMSimulator the system is a weakly coupled (co-simulation)
    system stepped by its fixed-step master at `step_size` (its default when None)."""
    annotation = etree.Element(ssc("Annotation"), type=OMS_ANNOTATION_TYPE)
    annotations = etree.SubElement(annotation, oms("Annotations"), nsmap={"oms": OMS_NS})
    information = etree.SubElement(annotations, oms("SimulationInformation"))
    etree.SubElement(information, oms("FixedStepMaster"), description=OMS_FIXED_STEP_MASTER,
                     stepSize=format_double(OMS_DEFAULT_STEP if step_size is None else step_size),
                     absoluteTolerance=format_double(OMS_TOLERANCE), relativeTolerance=format_double(OMS_TOLERANCE))
    return annotation
