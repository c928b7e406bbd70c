/* Start values of a parameterized FMU.
 *
 * `pendfmu export` writes FMUs whose parameter start values differ from the ones compiled
 * into the binary, without recompiling: the binary stays byte-identical, the model
 * description gets the new start values and a fresh GUID, and the resources folder gets
 * START_FILE:
 *
 *     guid {the new GUID}
 *     <value reference> <value>
 *     ...
 *
 * The binary accepts a GUID other than its own only if that file names it; the values
 * then become the instance's start values (after instantiation and after fmi2Reset), so
 * what the XML declares is what the binary computes with. Values are checked like
 * fmi2SetReal checks them: only parameters, finite, inside their physical range.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "framework.h"
#include "uri.h"

#define START_FILE "pendfmu-start.txt"

/* The start-value file in `directory` (a local path), if it names `guid`: its values
 * become inst->start. */
static bool accept_from_directory(Instance *inst, const char *guid, const char *directory) {
    char file_name[4200], line[256];
    const size_t length = strlen(directory);
    const int written = snprintf(file_name, sizeof file_name, "%s%s%s", directory,
                                 length && directory[length - 1] == LOCAL_PATH_SEPARATOR[0] ? "" : LOCAL_PATH_SEPARATOR,
                                 START_FILE);
    if (written < 0 || (size_t)written >= sizeof file_name) return false; /* a cut path would name another file */
    FILE *file = fopen(file_name, "r");
    if (!file) return false;
    bool accepted = false;
    if (fgets(line, sizeof line, file) && strncmp(line, "guid ", 5) == 0) {
        line[strcspn(line, "\r\n")] = 0;
        accepted = strcmp(line + 5, guid) == 0;
    }
    double values[N_REAL];
    memcpy(values, inst->start, sizeof values);
    int line_number = 1;
    while (accepted && fgets(line, sizeof line, file)) {
        line_number++;
        unsigned vr;
        double value;
        char extra;
        if (line[0] == '\n' || line[0] == '#') continue;
        if (sscanf(line, "%u %lf %c", &vr, &value, &extra) != 2 || vr >= N_REAL ||
            REAL_INFO[vr].causality != CAUSALITY_PARAMETER || !isfinite(value)) {
            log_error(inst, "%s line %d: expected '<parameter value reference> <finite value>'", START_FILE,
                      line_number);
            accepted = false;
            break;
        }
        const RealInfo *info = &REAL_INFO[vr];
        if ((info->has_low && (value < info->low || (info->low_open && value == info->low))) ||
            (info->has_high && value > info->high)) {
            log_error(inst, "%s line %d: %s = %g is outside its physical range", START_FILE, line_number, info->name,
                      value);
            accepted = false;
            break;
        }
        values[vr] = value;
    }
    fclose(file);
    if (accepted) memcpy(inst->start, values, sizeof values);
    return accepted;
}

bool start_values_accept(Instance *inst, const char *guid, const char *resource_location) {
    char directory[4096];
    if (!file_uri_to_path(resource_location, LOCAL_PATHS, directory, sizeof directory)) return false;
    return accept_from_directory(inst, guid, directory);
}

bool start_values_accept_path(Instance *inst, const char *token, const char *resource_path) {
    return resource_path && *resource_path && accept_from_directory(inst, token, resource_path);
}
