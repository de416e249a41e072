/*
 * fmu_harness: load FMI 2.0 or FMI 3.0 Co-Simulation libraries the way an importer does and run
 * them.
 *
 * Built with each target's C compiler (gcc, x86_64-w64-mingw32-gcc, aarch64-linux-gnu-gcc) and
 * run natively, under wine and under qemu-aarch64 by tests/python/test_platforms.py, which
 * compares the platforms' results. It loads each library with LoadLibrary/dlopen, resolves all
 * 44 fmi2 functions (Model Exchange's too) or all 75 of fmi3Functions.h, hands the FMU its
 * resource URI (FMI 2.0) or resource path (FMI 3.0) in the platform's form, and checks the
 * calls an importer relies on: a wrong GUID or instantiation token is refused, every call of the
 * run returns OK, and a panic inside the FMU comes back as an error with a log message.
 *
 *   fmu_harness run PLAN OUT.csv
 *   fmu_harness panic LIBRARY GUID VR [3]
 *
 * PLAN is a tab-separated text file (written by the test from an OSP system structure):
 *   fmi      VERSION                            2 (the default) or 3, before the fmu lines
 *   fmu      NAME LIBRARY RESOURCES GUID        one line per FMU, stepped in this order
 *                                               (FMI 3.0: RESOURCES a path, GUID the token)
 *   real     FMU VR VALUE                       a start value (FMU = index of its fmu line)
 *   integer  FMU VR VALUE
 *   connect  FROM VR TO VR                      a Real output to a Real input, set before TO steps
 *   record   FMU VR COLUMN                      a Real written to OUT.csv at every step
 *   clock    FMU VR                             FMI 3.0: instantiate FMU with Event Mode and tick
 *                                               its clock VR (1 ms) before each of its steps
 *   time     STEP STOP
 * `panic` sets the Real VR to 666 (the probe FMU panics on it), steps, and expects an error, an
 * "internal error" log message and a working reset (through FMI 3.0 with a trailing 3).
 *
 * The FMI types are declared here rather than taken from the standard's headers: only the
 * handful below cross the ABI, and the harness then builds with nothing but a C compiler.
 */
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <windows.h>
typedef HMODULE Library;
static Library open_library(const char *path) { return LoadLibraryA(path); }
static void *symbol(Library l, const char *name) { return (void *)GetProcAddress(l, name); }
static void close_library(Library l) { FreeLibrary(l); }
static const char *load_error(void) {
    static char buf[64];
    snprintf(buf, sizeof buf, "LoadLibrary error %lu", (unsigned long)GetLastError());
    return buf;
}
#else
#include <dlfcn.h>
typedef void *Library;
static Library open_library(const char *path) { return dlopen(path, RTLD_NOW | RTLD_LOCAL); }
static void *symbol(Library l, const char *name) { return dlsym(l, name); }
static void close_library(Library l) { dlclose(l); }
static const char *load_error(void) { return dlerror(); }
#endif

typedef void *fmi2Component;
typedef void *fmi2ComponentEnvironment;
typedef unsigned int fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef int fmi2Status; /* fmi2OK 0, Warning 1, Discard 2, Error 3, Fatal 4, Pending 5 */
enum { fmi2OK = 0, fmi2Error = 3 };

typedef struct {
    void (*logger)(fmi2ComponentEnvironment, const char *, fmi2Status, const char *, const char *, ...);
    void *(*allocateMemory)(size_t, size_t);
    void (*freeMemory)(void *);
    void (*stepFinished)(fmi2ComponentEnvironment, fmi2Status);
    fmi2ComponentEnvironment componentEnvironment;
} fmi2CallbackFunctions;

typedef fmi2Component (*Instantiate)(const char *, int, const char *, const char *,
                                     const fmi2CallbackFunctions *, fmi2Boolean, fmi2Boolean);
typedef void (*FreeInstance)(fmi2Component);
typedef fmi2Status (*SetupExperiment)(fmi2Component, fmi2Boolean, fmi2Real, fmi2Real, fmi2Boolean, fmi2Real);
typedef fmi2Status (*Simple)(fmi2Component);
typedef fmi2Status (*RealIO)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Real *);
typedef fmi2Status (*IntegerIO)(fmi2Component, const fmi2ValueReference *, size_t, fmi2Integer *);
typedef fmi2Status (*DoStep)(fmi2Component, fmi2Real, fmi2Real, fmi2Boolean);

/* FMI 3.0: fmi3Boolean is C99 bool, the logger is not variadic, the status values are FMI 2.0's. */
typedef void (*LogMessage3)(void *, int, const char *, const char *);
typedef void *(*Instantiate3)(const char *, const char *, const char *, bool, bool, bool, bool,
                              const unsigned int *, size_t, void *, LogMessage3, void *);
typedef int (*EnterInit3)(void *, bool, double, double, bool, double);
typedef int (*Float64IO)(void *, const unsigned int *, size_t, double *, size_t);
typedef int (*Int32IO)(void *, const unsigned int *, size_t, int32_t *, size_t);
typedef int (*DoStep3)(void *, double, double, bool, bool *, bool *, bool *, double *);
typedef int (*SetClock3)(void *, const unsigned int *, size_t, const bool *);
typedef int (*UpdateDiscreteStates3)(void *, bool *, bool *, bool *, bool *, bool *, double *);

/* The 75 functions of fmi3Functions.h (FMI 3.0.2), Model Exchange's and Scheduled Execution's
 * too: an importer may resolve them all, and FMPy does. */
static const char *const FUNCTIONS3[75] = {
    "fmi3ActivateModelPartition",
    "fmi3CompletedIntegratorStep",
    "fmi3DeserializeFMUState",
    "fmi3DoStep",
    "fmi3EnterConfigurationMode",
    "fmi3EnterContinuousTimeMode",
    "fmi3EnterEventMode",
    "fmi3EnterInitializationMode",
    "fmi3EnterStepMode",
    "fmi3EvaluateDiscreteStates",
    "fmi3ExitConfigurationMode",
    "fmi3ExitInitializationMode",
    "fmi3FreeFMUState",
    "fmi3FreeInstance",
    "fmi3GetAdjointDerivative",
    "fmi3GetBinary",
    "fmi3GetBoolean",
    "fmi3GetClock",
    "fmi3GetContinuousStateDerivatives",
    "fmi3GetContinuousStates",
    "fmi3GetDirectionalDerivative",
    "fmi3GetEventIndicators",
    "fmi3GetFMUState",
    "fmi3GetFloat32",
    "fmi3GetFloat64",
    "fmi3GetInt16",
    "fmi3GetInt32",
    "fmi3GetInt64",
    "fmi3GetInt8",
    "fmi3GetIntervalDecimal",
    "fmi3GetIntervalFraction",
    "fmi3GetNominalsOfContinuousStates",
    "fmi3GetNumberOfContinuousStates",
    "fmi3GetNumberOfEventIndicators",
    "fmi3GetNumberOfVariableDependencies",
    "fmi3GetOutputDerivatives",
    "fmi3GetShiftDecimal",
    "fmi3GetShiftFraction",
    "fmi3GetString",
    "fmi3GetUInt16",
    "fmi3GetUInt32",
    "fmi3GetUInt64",
    "fmi3GetUInt8",
    "fmi3GetVariableDependencies",
    "fmi3GetVersion",
    "fmi3InstantiateCoSimulation",
    "fmi3InstantiateModelExchange",
    "fmi3InstantiateScheduledExecution",
    "fmi3Reset",
    "fmi3SerializeFMUState",
    "fmi3SerializedFMUStateSize",
    "fmi3SetBinary",
    "fmi3SetBoolean",
    "fmi3SetClock",
    "fmi3SetContinuousStates",
    "fmi3SetDebugLogging",
    "fmi3SetFMUState",
    "fmi3SetFloat32",
    "fmi3SetFloat64",
    "fmi3SetInt16",
    "fmi3SetInt32",
    "fmi3SetInt64",
    "fmi3SetInt8",
    "fmi3SetIntervalDecimal",
    "fmi3SetIntervalFraction",
    "fmi3SetShiftDecimal",
    "fmi3SetShiftFraction",
    "fmi3SetString",
    "fmi3SetTime",
    "fmi3SetUInt16",
    "fmi3SetUInt32",
    "fmi3SetUInt64",
    "fmi3SetUInt8",
    "fmi3Terminate",
    "fmi3UpdateDiscreteStates",
};

/* The 44 functions of FMI 2.0, common, Co-Simulation and Model Exchange: every one must
 * resolve (an importer may resolve them all whichever interface it uses). */
static const char *const FUNCTIONS[44] = {
    "fmi2GetTypesPlatform", "fmi2GetVersion", "fmi2SetDebugLogging", "fmi2Instantiate",
    "fmi2FreeInstance", "fmi2SetupExperiment", "fmi2EnterInitializationMode",
    "fmi2ExitInitializationMode", "fmi2Terminate", "fmi2Reset", "fmi2GetReal", "fmi2GetInteger",
    "fmi2GetBoolean", "fmi2GetString", "fmi2SetReal", "fmi2SetInteger", "fmi2SetBoolean",
    "fmi2SetString", "fmi2GetFMUstate", "fmi2SetFMUstate", "fmi2FreeFMUstate",
    "fmi2SerializedFMUstateSize", "fmi2SerializeFMUstate", "fmi2DeSerializeFMUstate",
    "fmi2GetDirectionalDerivative", "fmi2SetRealInputDerivatives",
    "fmi2GetRealOutputDerivatives", "fmi2DoStep", "fmi2CancelStep", "fmi2GetStatus",
    "fmi2GetRealStatus", "fmi2GetIntegerStatus", "fmi2GetBooleanStatus", "fmi2GetStringStatus",
    "fmi2EnterEventMode", "fmi2NewDiscreteStates", "fmi2EnterContinuousTimeMode",
    "fmi2CompletedIntegratorStep", "fmi2SetTime", "fmi2SetContinuousStates", "fmi2GetDerivatives",
    "fmi2GetEventIndicators", "fmi2GetContinuousStates", "fmi2GetNominalsOfContinuousStates",
};

typedef struct {
    char *name;
    int version; /* 2 or 3 */
    Library lib;
    fmi2Component c;
    Instantiate instantiate;
    FreeInstance free_instance;
    SetupExperiment setup;
    Simple enter_init, exit_init, terminate, reset;
    RealIO get_real, set_real;
    IntegerIO set_integer;
    DoStep do_step;
    Instantiate3 instantiate3;
    EnterInit3 enter_init3;
    Float64IO get_float64, set_float64;
    Int32IO set_int32;
    DoStep3 do_step3;
    /* FMI 3.0 with a sample clock the harness ticks (plan line `clock`): in Event Mode. */
    bool clocked;
    fmi2ValueReference clock;
    Simple enter_event_mode, enter_step_mode;
    SetClock3 set_clock;
    UpdateDiscreteStates3 update_discrete_states;
} Fmu;

static char last_message[4096];

static void logger(fmi2ComponentEnvironment env, const char *instance, fmi2Status status,
                   const char *category, const char *format, ...) {
    va_list args;
    (void)env;
    va_start(args, format);
    vsnprintf(last_message, sizeof last_message, format, args);
    va_end(args);
    fprintf(stderr, "[%s %s status %d] %s\n", instance ? instance : "?", category ? category : "",
            status, last_message);
}

static const fmi2CallbackFunctions CALLBACKS = {logger, calloc, free, NULL, NULL};

static void logger3(void *env, int status, const char *category, const char *message) {
    (void)env;
    snprintf(last_message, sizeof last_message, "%s", message ? message : "");
    fprintf(stderr, "[fmi3 %s status %d] %s\n", category ? category : "", status, last_message);
}

static void die(const char *what, const char *detail) {
    fprintf(stderr, "fmu_harness: %s%s%s\n", what, detail ? ": " : "", detail ? detail : "");
    exit(1);
}

static void check(fmi2Status status, const Fmu *f, const char *call) {
    if (status != fmi2OK) {
        fprintf(stderr, "fmu_harness: %s of %s returned status %d\n", call, f->name, status);
        exit(1);
    }
}

static void *resolve(Fmu *f, const char *function) {
    void *p = symbol(f->lib, function);
    if (!p) die(function, "not exported");
    return p;
}

static void load(Fmu *f, const char *name, const char *path, int version) {
    int i;
    /* Every field starts defined (not clocked, no instance): the panic probe's Fmu is on the stack. */
    memset(f, 0, sizeof *f);
    f->name = strdup(name);
    f->version = version;
    f->lib = open_library(path);
    if (!f->lib) die(path, load_error());
    if (version == 3) {
        for (i = 0; i < (int)(sizeof FUNCTIONS3 / sizeof FUNCTIONS3[0]); i++) resolve(f, FUNCTIONS3[i]);
        f->instantiate3 = (Instantiate3)resolve(f, "fmi3InstantiateCoSimulation");
        f->free_instance = (FreeInstance)resolve(f, "fmi3FreeInstance");
        f->enter_init3 = (EnterInit3)resolve(f, "fmi3EnterInitializationMode");
        f->exit_init = (Simple)resolve(f, "fmi3ExitInitializationMode");
        f->terminate = (Simple)resolve(f, "fmi3Terminate");
        f->reset = (Simple)resolve(f, "fmi3Reset");
        f->get_float64 = (Float64IO)resolve(f, "fmi3GetFloat64");
        f->set_float64 = (Float64IO)resolve(f, "fmi3SetFloat64");
        f->set_int32 = (Int32IO)resolve(f, "fmi3SetInt32");
        f->do_step3 = (DoStep3)resolve(f, "fmi3DoStep");
        f->enter_event_mode = (Simple)resolve(f, "fmi3EnterEventMode");
        f->enter_step_mode = (Simple)resolve(f, "fmi3EnterStepMode");
        f->set_clock = (SetClock3)resolve(f, "fmi3SetClock");
        f->update_discrete_states = (UpdateDiscreteStates3)resolve(f, "fmi3UpdateDiscreteStates");
        return;
    }
    for (i = 0; i < 44; i++) resolve(f, FUNCTIONS[i]);
    f->instantiate = (Instantiate)resolve(f, "fmi2Instantiate");
    f->free_instance = (FreeInstance)resolve(f, "fmi2FreeInstance");
    f->setup = (SetupExperiment)resolve(f, "fmi2SetupExperiment");
    f->enter_init = (Simple)resolve(f, "fmi2EnterInitializationMode");
    f->exit_init = (Simple)resolve(f, "fmi2ExitInitializationMode");
    f->terminate = (Simple)resolve(f, "fmi2Terminate");
    f->reset = (Simple)resolve(f, "fmi2Reset");
    f->get_real = (RealIO)resolve(f, "fmi2GetReal");
    f->set_real = (RealIO)resolve(f, "fmi2SetReal");
    f->set_integer = (IntegerIO)resolve(f, "fmi2SetInteger");
    f->do_step = (DoStep)resolve(f, "fmi2DoStep");
}

/* Instantiate, after checking that a wrong GUID (instantiation token) is refused. */
static void instantiate(Fmu *f, const char *resources_text, const char *guid) {
    const char *resources = resources_text[0] ? resources_text : NULL;
    if (f->version == 3) {
        if (f->instantiate3(f->name, "{not-the-guid}", resources, false, false, false, false, NULL, 0, NULL, logger3, NULL))
            die(f->name, "accepted a wrong instantiation token");
        f->c = f->instantiate3(f->name, guid, resources, false, false, f->clocked, false, NULL, 0, NULL, logger3, NULL);
        if (!f->c) die(f->name, "fmi3InstantiateCoSimulation returned NULL (see the log above)");
        return;
    }
    if (f->instantiate(f->name, 1, "{not-the-guid}", resources, &CALLBACKS, 0, 0))
        die(f->name, "accepted a wrong GUID");
    f->c = f->instantiate(f->name, 1, guid, resources, &CALLBACKS, 0, 0);
    if (!f->c) die(f->name, "fmi2Instantiate returned NULL (see the log above)");
}

/* The calls of a run in either version. */
static int get_real(Fmu *f, fmi2ValueReference vr, double *v) {
    return f->version == 3 ? f->get_float64(f->c, &vr, 1, v, 1) : f->get_real(f->c, &vr, 1, v);
}

static int set_real(Fmu *f, fmi2ValueReference vr, double v) {
    return f->version == 3 ? f->set_float64(f->c, &vr, 1, &v, 1) : f->set_real(f->c, &vr, 1, &v);
}

static int set_integer(Fmu *f, fmi2ValueReference vr, int v) {
    int32_t w = v;
    return f->version == 3 ? f->set_int32(f->c, &vr, 1, &w, 1) : f->set_integer(f->c, &vr, 1, &v);
}

static int do_step(Fmu *f, double t, double h) {
    bool event = true, terminate = true, early = true;
    double last = -1.0;
    int status;
    if (f->version != 3) return f->do_step(f->c, t, h, 1);
    status = f->do_step3(f->c, t, h, true, &event, &terminate, &early, &last);
    /* A clocked FMU asks for Event Mode at the end of each step: its next tick is there. */
    if (status == fmi2OK && (event != f->clocked || terminate || early || last != t + h))
        die(f->name, "fmi3DoStep's outputs are not a completed step (with Event Mode due at a tick)");
    return status;
}

/* A tick of a clocked FMU at t, in Event Mode (entered here but at the first, where
 * initialisation left it): the clock activated, the discrete states updated, the next tick at
 * t + h, then Step Mode. */
static void tick(Fmu *f, long k, double t, double h) {
    bool need = true, terminate = true, nominals = true, values = true, defined = false;
    double next = 0.0;
    const bool on = true;
    if (k > 0) check(f->enter_event_mode(f->c), f, "fmi3EnterEventMode");
    check(f->set_clock(f->c, &f->clock, 1, &on), f, "fmi3SetClock");
    check(f->update_discrete_states(f->c, &need, &terminate, &nominals, &values, &defined, &next), f,
          "fmi3UpdateDiscreteStates");
    if (need || terminate || values || !defined || next - (t + h) > 1e-12 || (t + h) - next > 1e-12)
        die(f->name, "fmi3UpdateDiscreteStates did not tick to the next tick");
    check(f->enter_step_mode(f->c), f, "fmi3EnterStepMode");
}

/* Before the start values (FMI 2.0's experiment setup); after them, initialisation. */
static void setup(Fmu *f, double stop) {
    if (f->version != 3) check(f->setup(f->c, 0, 0.0, 0.0, stop > 0, stop), f, "fmi2SetupExperiment");
}

static void initialise(Fmu *f, double stop) {
    if (f->version == 3) {
        check(f->enter_init3(f->c, false, 0.0, 0.0, stop > 0, stop), f, "fmi3EnterInitializationMode");
        check(f->exit_init(f->c), f, "fmi3ExitInitializationMode");
    } else {
        check(f->enter_init(f->c), f, "fmi2EnterInitializationMode");
        check(f->exit_init(f->c), f, "fmi2ExitInitializationMode");
    }
}

/* Split a line at tabs in place; returns the number of fields. */
static int fields(char *line, char **out, int max) {
    int n = 0;
    char *p = line;
    line[strcspn(line, "\r\n")] = 0;
    while (n < max) {
        out[n++] = p;
        p = strchr(p, '\t');
        if (!p) break;
        *p++ = 0;
    }
    return n;
}

enum { MAX_FMUS = 8, MAX_ITEMS = 256 };
/* The interval of the controllers' sample clock (their modelDescription.xml's intervalDecimal). */
static const double CLOCK_INTERVAL = 0.001;
typedef struct { int fmu; fmi2ValueReference vr; double value; int integer; } Start;
typedef struct { int from; fmi2ValueReference from_vr; int to; fmi2ValueReference to_vr; } Connection;
typedef struct { int fmu; fmi2ValueReference vr; char *column; } Record;

static int index_of(const char *s, int n) {
    int i = atoi(s);
    if (i < 0 || i >= n) die("plan names an FMU that has no fmu line", s);
    return i;
}

static int run(const char *plan_path, const char *out_path) {
    static Fmu fmus[MAX_FMUS];
    static char *uris[MAX_FMUS], *guids[MAX_FMUS];
    static Start starts[MAX_ITEMS];
    static Connection connections[MAX_ITEMS];
    static Record records[MAX_ITEMS];
    int n_fmus = 0, n_starts = 0, n_connections = 0, n_records = 0, i, j, version = 2;
    double step = 0, stop = 0;
    long k, steps;
    char line[8192], *f[8];
    FILE *plan = fopen(plan_path, "r"), *out;
    if (!plan) die("cannot open the plan", plan_path);
    while (fgets(line, sizeof line, plan)) {
        int n = fields(line, f, 8);
        if (!strcmp(f[0], "fmi") && n == 2 && n_fmus == 0) {
            version = atoi(f[1]);
            if (version != 2 && version != 3) die("fmi: the version is 2 or 3", f[1]);
        } else if (!strcmp(f[0], "fmu") && n == 5 && n_fmus < MAX_FMUS) {
            load(&fmus[n_fmus], f[1], f[2], version);
            uris[n_fmus] = strdup(f[3]);
            guids[n_fmus] = strdup(f[4]);
            n_fmus++;
        } else if ((!strcmp(f[0], "real") || !strcmp(f[0], "integer")) && n == 4 && n_starts < MAX_ITEMS) {
            Start s = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10),
                       strtod(f[3], NULL), !strcmp(f[0], "integer")};
            starts[n_starts++] = s;
        } else if (!strcmp(f[0], "connect") && n == 5 && n_connections < MAX_ITEMS) {
            Connection c = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10),
                            index_of(f[3], n_fmus), (fmi2ValueReference)strtoul(f[4], NULL, 10)};
            connections[n_connections++] = c;
        } else if (!strcmp(f[0], "record") && n == 4 && n_records < MAX_ITEMS) {
            Record r = {index_of(f[1], n_fmus), (fmi2ValueReference)strtoul(f[2], NULL, 10), strdup(f[3])};
            records[n_records++] = r;
        } else if (!strcmp(f[0], "clock") && n == 3 && version == 3) {
            Fmu *m = &fmus[index_of(f[1], n_fmus)];
            m->clocked = true;
            m->clock = (fmi2ValueReference)strtoul(f[2], NULL, 10);
        } else if (!strcmp(f[0], "time") && n == 3) {
            step = strtod(f[1], NULL);
            stop = strtod(f[2], NULL);
        } else if (f[0][0]) {
            die("unreadable plan line", f[0]);
        }
    }
    fclose(plan);
    if (n_fmus == 0 || step <= 0 || stop <= 0) die("the plan needs fmu lines and a time line", NULL);

    for (i = 0; i < n_fmus; i++) {
        Fmu *m = &fmus[i];
        if (m->clocked && step != CLOCK_INTERVAL) die(m->name, "a clocked FMU ticks every 1 ms: the plan's step must be 0.001");
        instantiate(m, uris[i], guids[i]);
        setup(m, stop);
        for (j = 0; j < n_starts; j++) {
            if (starts[j].fmu != i) continue;
            if (starts[j].integer)
                check(set_integer(m, starts[j].vr, (int)starts[j].value), m, "set an Integer");
            else
                check(set_real(m, starts[j].vr, starts[j].value), m, "set a Real");
        }
        initialise(m, stop);
    }

    out = fopen(out_path, "w");
    if (!out) die("cannot write", out_path);
    fprintf(out, "time");
    for (j = 0; j < n_records; j++) fprintf(out, ",%s", records[j].column);
    fprintf(out, "\n");
    /* Gauss-Seidel: before an FMU steps, its inputs take the current outputs of its sources. */
    steps = (long)(stop / step + 0.5);
    for (k = 0; k < steps; k++) {
        double t = k * step;
        for (i = 0; i < n_fmus; i++) {
            for (j = 0; j < n_connections; j++) {
                Connection *c = &connections[j];
                fmi2Real v;
                if (c->to != i) continue;
                check(get_real(&fmus[c->from], c->from_vr, &v), &fmus[c->from], "get a Real");
                check(set_real(&fmus[i], c->to_vr, v), &fmus[i], "set a Real");
            }
            if (fmus[i].clocked) tick(&fmus[i], k, t, step);
            check(do_step(&fmus[i], t, step), &fmus[i], "DoStep");
        }
        fprintf(out, "%.17g", (k + 1) * step);
        for (j = 0; j < n_records; j++) {
            fmi2Real v;
            check(get_real(&fmus[records[j].fmu], records[j].vr, &v), &fmus[records[j].fmu], "get a Real");
            fprintf(out, ",%.17g", v);
        }
        fprintf(out, "\n");
    }
    fclose(out);
    for (i = 0; i < n_fmus; i++) {
        check(fmus[i].terminate(fmus[i].c), &fmus[i], "Terminate");
        fmus[i].free_instance(fmus[i].c);
        close_library(fmus[i].lib);
    }
    printf("fmu_harness: FMI %d.0, %d FMUs, %ld steps, %d columns -> %s\n", version, n_fmus, steps, n_records, out_path);
    return 0;
}

static int panic_probe(const char *library, const char *guid, const char *vr_text, int version) {
    Fmu m;
    fmi2ValueReference vr = (fmi2ValueReference)strtoul(vr_text, NULL, 10);
    int status;
    load(&m, "probe", library, version);
    instantiate(&m, "", guid);
    setup(&m, 0.0);
    initialise(&m, 0.0);
    check(set_real(&m, vr, 666.0), &m, "set a Real");
    last_message[0] = 0;
    status = do_step(&m, 0.0, 0.1);
    if (status != fmi2Error) {
        fprintf(stderr, "fmu_harness: the panicking DoStep returned %d, not an error\n", status);
        return 1;
    }
    if (!strstr(last_message, "internal error")) die("no 'internal error' log message after the panic", last_message);
    check(m.reset(m.c), &m, "Reset after the panic");
    m.free_instance(m.c);
    close_library(m.lib);
    printf("fmu_harness: panic -> fmi%dError, logged \"%s\", reset OK\n", version, last_message);
    return 0;
}

int main(int argc, char **argv) {
    if (argc == 4 && !strcmp(argv[1], "run")) return run(argv[2], argv[3]);
    if (argc == 5 && !strcmp(argv[1], "panic")) return panic_probe(argv[2], argv[3], argv[4], 2);
    if (argc == 6 && !strcmp(argv[1], "panic") && !strcmp(argv[5], "3")) return panic_probe(argv[2], argv[3], argv[4], 3);
    fprintf(stderr, "usage: fmu_harness run PLAN OUT.csv | fmu_harness panic LIBRARY GUID VR [3]\n");
    return 2;
}
