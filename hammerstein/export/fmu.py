"""FMI 2.0 co-simulation FMU around the exported C code (a source-code FMU).

The archive holds ``modelDescription.xml`` (one Real input per reference, one
Real output per voltage and an Integer output ``status``, fixed
communication step = the sampling period), ``sources/`` with ``NAME.h``,
``NAME.c`` and the FMI wrapper ``fmi2.c``, and, when a C compiler is found,
``binaries/linux64/NAME.so`` (or the platform's folder) for the machine it is
built on. The wrapper follows the FMI 2.0 standard (Modelica Association,
fmi-standard.org, Section 4 "FMI for Co-Simulation"): each ``fmi2DoStep`` of
size T calls ``NAME_step`` once with the inputs set for the communication
point and sets the outputs of the next one; a step of n T calls it n times.
Importers compile the sources with their own FMI 2.0 headers; the binary
built here uses fmpy's copy of the official headers when fmpy is installed
and otherwise :data:`FMI2_MINIMAL_HEADER` (the same types and calling
convention).
"""

from __future__ import annotations

import io
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.sax.saxutils import quoteattr

from hammerstein.exceptions import ExportError
from hammerstein.export.c_code import CExport

__all__ = ["model_description", "fmi2_wrapper", "build_fmu", "compile_binary", "find_compiler",
           "platform_folder", "fmu_owned", "FMI2_MINIMAL_HEADER", "GENERATION_TOOL"]

#: ``generationTool`` attribute of the model descriptions written here (ownership mark).
GENERATION_TOOL = "hammerstein export"

#: The subset of the FMI 2.0 headers (``fmi2TypesPlatform.h``,
#: ``fmi2FunctionTypes.h``) the wrapper uses: types of the standard.
FMI2_MINIMAL_HEADER = """/* Minimal FMI 2.0 declarations (types of fmi2TypesPlatform.h and fmi2FunctionTypes.h,
   FMI 2.0 standard, Modelica Association), used when the official headers are not at hand. */
#ifndef fmi2Functions_h
#define fmi2Functions_h
#include <stddef.h>
#if defined(_WIN32)
#define FMI2_Export __declspec(dllexport)
#else
#define FMI2_Export __attribute__((visibility("default")))
#endif
typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef void *fmi2FMUstate;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef char fmi2Char;
typedef const fmi2Char *fmi2String;
typedef char fmi2Byte;
#define fmi2True 1
#define fmi2False 0
#define fmi2TypesPlatform "default"
#define fmi2Version "2.0"
typedef enum { fmi2OK, fmi2Warning, fmi2Discard, fmi2Error, fmi2Fatal, fmi2Pending } fmi2Status;
typedef enum { fmi2ModelExchange, fmi2CoSimulation } fmi2Type;
typedef enum { fmi2DoStepStatus, fmi2PendingStatus, fmi2LastSuccessfulTime, fmi2Terminated } fmi2StatusKind;
typedef void (*fmi2CallbackLogger)(fmi2ComponentEnvironment, fmi2String, fmi2Status, fmi2String, fmi2String, ...);
typedef void *(*fmi2CallbackAllocateMemory)(size_t, size_t);
typedef void (*fmi2CallbackFreeMemory)(void *);
typedef void (*fmi2StepFinished)(fmi2ComponentEnvironment, fmi2Status);
typedef struct {
    const fmi2CallbackLogger logger;
    const fmi2CallbackAllocateMemory allocateMemory;
    const fmi2CallbackFreeMemory freeMemory;
    const fmi2StepFinished stepFinished;
    const fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;
#endif
"""


def _xml(text):
    return quoteattr(str(text))


def model_description(code: CExport, guid=None, version=""):
    """The ``modelDescription.xml`` of the FMU.

    Parameters
    ----------
    code : CExport
        The exported C code.
    guid : str, optional
        Default: a UUID4 in braces.
    version : str
        hammerstein version, in ``generationTool``.

    Returns
    -------
    str
        FMI 2.0 model description (co-simulation, source files listed).
    """
    guid = guid or "{" + str(uuid.uuid4()) + "}"
    p, m, N = code.n_outputs, code.n_inputs, code.name
    q = _n_measured(code)
    rows = []
    rest = list(getattr(code, "rest_reference", None) or [0.0] * len(code.output_names))
    sensed = list(getattr(code, "rest_measurement", None) or rest)   # what the sensor reads at rest
    for i, nm in enumerate(code.output_names):      # starting at rest: no step at the 1st call
        rows.append(f'    <ScalarVariable name={_xml("reference_" + nm)} valueReference="{i}" '
                    f'causality="input" variability="discrete" '
                    f'description={_xml(f"reference of output {nm}, {code.preview} sample(s) ahead [um]")}>'
                    f'\n      <Real start="{float(rest[i])!r}" unit="um"/>\n    </ScalarVariable>')
    for i, nm in enumerate(code.output_names[:q]):
        rows.append(f'    <ScalarVariable name={_xml("measurement_" + nm)} valueReference="{p + i}" '
                    f'causality="input" variability="discrete" '
                    f'description={_xml(f"measured displacement {nm} of the current sample [um]")}>'
                    f'\n      <Real start="{float(sensed[i])!r}" unit="um"/>\n    </ScalarVariable>')
    p += q          # the value references of the outputs follow the inputs
    for k, nm in enumerate(code.input_names):
        rows.append(f'    <ScalarVariable name={_xml("voltage_" + nm)} valueReference="{p + k}" '
                    f'causality="output" variability="discrete" initial="exact" '
                    f'description={_xml(f"amplifier input {nm} [V]")}>'
                    f'\n      <Real start="0.0" unit="V"/>\n    </ScalarVariable>')
    rows.append(f'    <ScalarVariable name="status" valueReference="{p + m}" causality="output" '
                f'variability="discrete" initial="exact" description="bits of {N}_step: '
                f'1 amplifier limit hit, 2 divergence detected (voltages held), 4 input not '
                f'finite or out of the model range">'
                f'\n      <Integer start="0"/>\n    </ScalarVariable>')
    outputs = "\n".join(f'      <Unknown index="{p + k + 1}"/>' for k in range(m + 1))
    sources = "\n".join(f'      <File name="{f}"/>' for f in _c_sources(code) + ["fmi2.c"])
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName={_xml(N)} guid={_xml(guid)}
  description={_xml(code.description)}
  generationTool={_xml(f"{GENERATION_TOOL} {version}".strip())}
  variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier={_xml(N)} canHandleVariableCommunicationStepSize="false"
    canInterpolateInputs="false" canBeInstantiatedOnlyOncePerProcess="false"
    canNotUseMemoryManagementFunctions="false" canGetAndSetFMUstate="false"
    canSerializeFMUstate="false" providesDirectionalDerivative="false">
    <SourceFiles>
{sources}
    </SourceFiles>
  </CoSimulation>
  <UnitDefinitions>
    <Unit name="V"/>
    <Unit name="um"/>
  </UnitDefinitions>
  <DefaultExperiment startTime="0.0" stepSize="{code.sampling_period!r}"/>
  <ModelVariables>
{chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>
{outputs}
    </Outputs>
  </ModelStructure>
</fmiModelDescription>
"""


def fmi2_wrapper(code: CExport, guid):
    """C source of the FMI 2.0 co-simulation wrapper (``sources/fmi2.c``).

    Parameters
    ----------
    code : CExport
        The exported C code it calls.
    guid : str
        The model description's GUID (checked by ``fmi2Instantiate``).

    Returns
    -------
    str
    """
    N, p, m = code.name, code.n_outputs, code.n_inputs
    q = _n_measured(code)
    call = (f"{N}_step(&i->state, i->reference, i->measurement, i->voltage)" if q
            else f"{N}_step(&i->state, i->reference, i->voltage)")
    rest = list(getattr(code, "rest_reference", None) or [0.0] * p)
    rest_init = ", ".join(repr(float(v)) for v in rest)
    sensed = list(getattr(code, "rest_measurement", None) or rest)
    sensed_init = ", ".join(repr(float(v)) for v in sensed)
    return f"""/* FMI 2.0 co-simulation wrapper of {N}; generated by hammerstein export. */
#include <string.h>
#include "fmi2Functions.h"
#include "{N}.h"

#define NU {p}
#define NM {q}
#define NY {m}
#define GUID {_c_string(guid)}

typedef struct {{
    {N}_state state;
    {N}_real reference[NU];      /* the compensator's own type (double or float) */
    {N}_real measurement[NM > 0 ? NM : 1];   /* closed loop: the sensor's displacements */
    {N}_real voltage[NY];
    int status;
    double time;
    fmi2CallbackFunctions cb;
    fmi2String name;
    int logging;
    int told_step;               /* the note on a step longer than T is logged once */
}} Instance;

/* the model's output at 0 V [um]: where {N}_init leaves the compensator (the references'
   start values in modelDescription.xml) */
static const {N}_real rest_reference[NU] = {{{rest_init}}};
static const {N}_real rest_measurement[NU] = {{{sensed_init}}};

static void say(Instance *c, fmi2Status st, const char *msg)
{{
    if (c && c->cb.logger) c->cb.logger(c->cb.componentEnvironment, c->name, st, "error", msg);
}}

FMI2_Export const char *fmi2GetTypesPlatform(void) {{ return fmi2TypesPlatform; }}
FMI2_Export const char *fmi2GetVersion(void) {{ return fmi2Version; }}

FMI2_Export fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[])
{{
    (void)n; (void)cat;
    if (!c) return fmi2Error;
    ((Instance *)c)->logging = on;
    return fmi2OK;
}}

FMI2_Export fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                                          fmi2String location, const fmi2CallbackFunctions *cb,
                                          fmi2Boolean visible, fmi2Boolean logging)
{{
    Instance *c;
    (void)location; (void)visible;
    if (!cb || !cb->allocateMemory || !cb->freeMemory) return NULL;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0) {{
        if (cb->logger) cb->logger(cb->componentEnvironment, name, fmi2Error, "error",
                                   "{N}: co-simulation only, and the GUID must match modelDescription.xml");
        return NULL;
    }}
    c = (Instance *)cb->allocateMemory(1, sizeof(Instance));
    if (!c) return NULL;
    memcpy((void *)&c->cb, cb, sizeof *cb);
    c->name = name;
    c->logging = logging;
    c->told_step = 0;
    {N}_init(&c->state);
    memcpy(c->reference, rest_reference, sizeof c->reference);   /* the start values: at rest */
    memset(c->measurement, 0, sizeof c->measurement);
    {{ int k; for (k = 0; k < NM; ++k) c->measurement[k] = rest_measurement[k]; }}
    memset(c->voltage, 0, sizeof c->voltage);
    c->status = 0;
    c->time = 0.0;
    return c;
}}

FMI2_Export void fmi2FreeInstance(fmi2Component c)
{{
    if (c) ((Instance *)c)->cb.freeMemory(c);
}}

FMI2_Export fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol,
                                           fmi2Real start, fmi2Boolean stopDef, fmi2Real stop)
{{
    (void)tolDef; (void)tol; (void)stopDef; (void)stop;
    if (!c) return fmi2Error;
    ((Instance *)c)->time = start;
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2EnterInitializationMode(fmi2Component c) {{ return c ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2ExitInitializationMode(fmi2Component c) {{ return c ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2Terminate(fmi2Component c) {{ return c ? fmi2OK : fmi2Error; }}

FMI2_Export fmi2Status fmi2Reset(fmi2Component c)
{{
    Instance *i = (Instance *)c;
    if (!i) return fmi2Error;
    {N}_init(&i->state);
    memcpy(i->reference, rest_reference, sizeof i->reference);
    memset(i->measurement, 0, sizeof i->measurement);
    {{ int k; for (k = 0; k < NM; ++k) i->measurement[k] = rest_measurement[k]; }}
    memset(i->voltage, 0, sizeof i->voltage);
    i->status = 0;
    i->told_step = 0;
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[])
{{
    Instance *i = (Instance *)c;
    size_t k;
    if (!i) return fmi2Error;
    for (k = 0; k < n; ++k) {{
        if (vr[k] < NU) v[k] = (fmi2Real)i->reference[vr[k]];
        else if (vr[k] < NU + NM) v[k] = (fmi2Real)i->measurement[vr[k] - NU];
        else if (vr[k] < NU + NM + NY) v[k] = (fmi2Real)i->voltage[vr[k] - NU - NM];
        else {{ say(i, fmi2Error, "fmi2GetReal: unknown value reference"); return fmi2Error; }}
    }}
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real v[])
{{
    Instance *i = (Instance *)c;
    size_t k;
    if (!i) return fmi2Error;
    for (k = 0; k < n; ++k) {{
        if (vr[k] < NU) i->reference[vr[k]] = ({N}_real)v[k];
        else if (vr[k] < NU + NM) i->measurement[vr[k] - NU] = ({N}_real)v[k];
        else {{ say(i, fmi2Error, "fmi2SetReal: only the references and measurements are inputs"); return fmi2Error; }}
    }}
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[])
{{
    Instance *i = (Instance *)c;
    size_t k;
    if (!i) return fmi2Error;
    for (k = 0; k < n; ++k) {{
        if (vr[k] == NU + NM + NY) v[k] = i->status;
        else {{ say(i, fmi2Error, "fmi2GetInteger: unknown value reference"); return fmi2Error; }}
    }}
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[])
{{ (void)vr; (void)v; return (c && n == 0) ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[])
{{ (void)vr; (void)v; return (c && n == 0) ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[])
{{ (void)vr; (void)v; return (c && n == 0) ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[])
{{ (void)vr; (void)v; return (c && n == 0) ? fmi2OK : fmi2Error; }}
FMI2_Export fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[])
{{ (void)vr; (void)v; return (c && n == 0) ? fmi2OK : fmi2Error; }}

FMI2_Export fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {{ (void)c; (void)s; return fmi2Error; }}
FMI2_Export fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {{ (void)c; (void)s; return fmi2Error; }}
FMI2_Export fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {{ (void)c; (void)s; return fmi2Error; }}
FMI2_Export fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n)
{{ (void)c; (void)s; (void)n; return fmi2Error; }}
FMI2_Export fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n)
{{ (void)c; (void)s; (void)b; (void)n; return fmi2Error; }}
FMI2_Export fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s)
{{ (void)c; (void)s; (void)b; (void)n; return fmi2Error; }}
FMI2_Export fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu,
        const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[])
{{ (void)c; (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz; return fmi2Error; }}
FMI2_Export fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], const fmi2Real v[])
{{ (void)c; (void)vr; (void)n; (void)order; (void)v; return fmi2Error; }}
FMI2_Export fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
        const fmi2Integer order[], fmi2Real v[])
{{ (void)c; (void)vr; (void)n; (void)order; (void)v; return fmi2Error; }}

/* One communication step of n sampling periods: n calls of {N}_step with the inputs held. */
FMI2_Export fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noPrior)
{{
    Instance *i = (Instance *)c;
    double ratio;
    long n, k;
    (void)noPrior;
    if (!i) return fmi2Error;
    ratio = h / {float(code.sampling_period)!r};   /* {N}_SAMPLING_PERIOD, in double */
    n = (long)(ratio + 0.5);
    if (h == 0.0) {{      /* FMI 2.0: a zero step is allowed; nothing runs, the outputs stay */
        i->time = t;
        return fmi2OK;
    }}
    if (n < 1 || (ratio - (double)n) > 1e-6 || ((double)n - ratio) > 1e-6) {{
        say(i, fmi2Error, "fmi2DoStep: the communication step must be 0 or a multiple of the sampling period");
        return fmi2Error;
    }}
    if (n > 1 && !i->told_step) {{
        i->told_step = 1;
        if (i->cb.logger)
            i->cb.logger(i->cb.componentEnvironment, i->name, fmi2Warning, "warning",
                         "fmi2DoStep: a communication step of several sampling periods holds the "
                         "references over it and shows the voltages only at its end: the "
                         "compensator tracks as designed only with a step of one sampling period "
                         "(stepSize of DefaultExperiment)");
    }}
    i->status = 0;
    for (k = 0; k < n; ++k) i->status |= {call};
    i->time = t + h;
    return fmi2OK;
}}

FMI2_Export fmi2Status fmi2CancelStep(fmi2Component c) {{ (void)c; return fmi2Error; }}
FMI2_Export fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v)
{{ (void)c; (void)s; (void)v; return fmi2Discard; }}
FMI2_Export fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v)
{{
    Instance *i = (Instance *)c;
    if (!i || s != fmi2LastSuccessfulTime) return fmi2Discard;
    *v = i->time;
    return fmi2OK;
}}
FMI2_Export fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v)
{{ (void)c; (void)s; (void)v; return fmi2Discard; }}
FMI2_Export fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v)
{{ (void)c; (void)s; (void)v; return fmi2Discard; }}
FMI2_Export fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v)
{{ (void)c; (void)s; (void)v; return fmi2Discard; }}
"""


def _n_measured(code):
    """Measurement inputs of the step: p for a closed-loop export, else 0."""
    return int(code.n_outputs) if getattr(code, "measured", False) else 0


def _c_sources(code):
    """The C sources to compile (the compensator's, and a closed loop's feedforward)."""
    return [f for f in code.files() if f.endswith(".c")]


def _c_string(text):
    return '"' + str(text).replace("\\", "\\\\").replace('"', '\\"') + '"'


def platform_folder():
    """The FMI 2.0 ``binaries/`` folder of this machine, or None when unknown.

    Returns
    -------
    str or None
        ``'linux64'``, ``'darwin64'``, ``'win64'``, ... (FMI 2.0, Section 2.3).
    """
    bits = "64" if sys.maxsize > 2 ** 32 else "32"
    system = {"Linux": "linux", "Darwin": "darwin", "Windows": "win"}.get(platform.system())
    return None if system is None else system + bits


def find_compiler():
    """Path of a C compiler (``$CC``, cc, gcc, clang), or None.

    Returns
    -------
    str or None
    """
    for name in ([os.environ["CC"]] if os.environ.get("CC") else []) + ["cc", "gcc", "clang"]:
        path = shutil.which(name)
        if path:
            return path
    return None


def _fmi_include_dir():
    """fmpy's copy of the official FMI headers, when fmpy is installed (else None)."""
    try:
        import importlib.util
        spec = importlib.util.find_spec("fmpy")
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.origin:
        return None
    inc = Path(spec.origin).parent / "c-code"
    return inc if (inc / "fmi2Functions.h").is_file() else None


def compile_binary(code: CExport, wrapper, compiler=None):
    """Compile the FMU's shared library for this machine.

    Parameters
    ----------
    code : CExport
        The exported C code.
    wrapper : str
        The FMI wrapper source (:func:`fmi2_wrapper`).
    compiler : str, optional
        Default :func:`find_compiler`.

    Returns
    -------
    (folder, filename, data) or None
        ``binaries/<folder>/<filename>`` and its bytes; None without a
        compiler or for an unknown platform.

    Raises
    ------
    ExportError
        The compiler failed (its first error line).
    """
    cc = compiler or find_compiler()
    folder = platform_folder()
    if cc is None or folder is None:
        return None
    ext = {"linux": ".so", "darwin": ".dylib", "win": ".dll"}[folder.rstrip("0123456789")]
    with tempfile.TemporaryDirectory(prefix="hammerstein-fmu-") as tmp:
        tmp = Path(tmp)
        sources = {**code.files(), "fmi2.c": wrapper}
        inc = _fmi_include_dir()
        if inc is None:
            sources["fmi2Functions.h"] = FMI2_MINIMAL_HEADER
        for fname, text in sources.items():
            try:        # the build's own directory: no other file to guard, a failure is said
                (tmp / fname).write_text(text, encoding="utf-8")
            except OSError as exc:
                raise ExportError(f"fmu: its binary cannot be built: the sources could not be "
                                  f"written to a temporary directory ({exc.strerror}); "
                                  f"--no-binary writes the FMU with its sources only") from None
        lib = tmp / (code.name + ext)
        cmd = [cc, "-std=c99", "-O2", "-shared", "-fPIC", "-I", str(tmp)] \
            + (["-I", str(inc)] if inc else []) \
            + ["-o", str(lib), *(str(tmp / f) for f in _c_sources(code)), str(tmp / "fmi2.c"),
               "-lm"]
        res = subprocess.run(cmd, capture_output=True, text=True)
        if res.returncode:
            first = next((ln for ln in res.stderr.splitlines() if "error" in ln), res.stderr.strip()[:200])
            if not first:       # killed (e.g. by a file-size limit): no message of its own
                first = f"exit status {res.returncode}, no message"
            raise ExportError(f"fmu: the C compiler {cc} failed on the FMU sources: {first}; "
                              f"--no-binary writes the FMU with its sources only")
        return folder, lib.name, lib.read_bytes()


def build_fmu(code: CExport, version="", binary=True, compiler=None, guid=None):
    """The FMU archive (a zip file) of an exported compensator.

    Parameters
    ----------
    code : CExport
        The exported C code.
    version : str
        hammerstein version (model description ``generationTool``).
    binary : bool
        Also compile ``binaries/<platform>/NAME.<so|dylib|dll>`` when a C
        compiler is found.
    compiler : str, optional
        C compiler to use.
    guid : str, optional
        Default: a new UUID.

    Returns
    -------
    (data, binary_path) : (bytes, str or None)
        The archive and the binary's path inside it (None when none was
        built).

    Raises
    ------
    ExportError
        The compiler failed on the sources.
    """
    guid = guid or "{" + str(uuid.uuid4()) + "}"
    wrapper = fmi2_wrapper(code, guid)
    built = compile_binary(code, wrapper, compiler) if binary else None
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("modelDescription.xml", model_description(code, guid, version))
        for fname, text in code.files().items():
            z.writestr(f"sources/{fname}", text)
        z.writestr("sources/fmi2.c", wrapper)
        z.writestr("documentation/index.html",
                   f"<html><body><h1>{code.name}</h1><p>{code.description}.</p><p>Inputs: the "
                   f"references of {', '.join(code.output_names)} [um], {code.preview} sample(s) "
                   f"ahead{_measured_text(code)}; outputs: the voltages of {', '.join(code.input_names)} [V] and "
                   f"<code>status</code> (1 amplifier limit, 2 divergence, 4 input not finite "
                   f"or out of range). See "
                   f"<code>sources/{code.name}.h</code>.</p></body></html>\n")
        path = None
        if built:
            folder, fname, data = built
            path = f"binaries/{folder}/{fname}"
            z.writestr(path, data)
    return buf.getvalue(), path


def _measured_text(code):
    q = _n_measured(code)
    return (f", and the measured displacements of {', '.join(code.output_names[:q])} [um]"
            if q else "")


def fmu_owned(path):
    """True when ``path`` is an FMU written by hammerstein export.

    Parameters
    ----------
    path : str or pathlib.Path
        An existing file.

    Returns
    -------
    bool
        It is a zip archive whose ``modelDescription.xml`` names
        :data:`GENERATION_TOOL` as its generation tool.
    """
    try:
        with zipfile.ZipFile(path) as z:
            info = z.getinfo("modelDescription.xml")
            if info.file_size > 4 << 20:
                return False
            text = z.read(info).decode("utf-8", "replace")
    except (OSError, KeyError, zipfile.BadZipFile):
        return False
    return f'generationTool="{GENERATION_TOOL}' in text
