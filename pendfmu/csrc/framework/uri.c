/* File URIs to local paths (see uri.h).
 *
 * RFC 8089 allows "file:/path", "file:///path" and "file://host/path"; Windows importers
 * write a drive as "file:///C:/dir" (older ones "file:///C|/dir") and a share as
 * "file://server/share/dir". A path is percent-decoded before its Windows form is worked
 * out, so an escaped drive colon ("C%3A") is still a drive.
 */
#include <string.h>

#include "uri.h"

static int hex_digit(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

static bool is_letter(char c) { return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z'); }

/* Whether `text` starts with the lower-case `prefix`, ignoring the case of letters. */
static bool starts_with_nocase(const char *text, const char *prefix) {
    for (; *prefix; text++, prefix++) {
        char c = *text;
        if (c >= 'A' && c <= 'Z') c = (char)(c - 'A' + 'a');
        if (c != *prefix) return false;
    }
    return true;
}

/* Append `from` to path[*n], decoding %XX escapes; false for a malformed escape, an
 * escaped NUL (it would cut the path short) or no room left. */
static bool append_decoded(const char *from, char *path, size_t size, size_t *n) {
    for (; *from; from++) {
        char c = *from;
        if (c == '%') {
            const int high = hex_digit(from[1]);
            const int low = high < 0 ? -1 : hex_digit(from[2]);
            if (low < 0 || (high == 0 && low == 0)) return false;
            c = (char)(high * 16 + low);
            from += 2;
        }
        if (*n + 1 >= size) return false;
        path[(*n)++] = c;
    }
    path[*n] = 0;
    return true;
}

bool file_uri_to_path(const char *uri, PathStyle style, char *path, size_t size) {
    if (!uri || !path || size == 0 || !starts_with_nocase(uri, "file:")) return false;
    const char *rest = uri + 5;
    size_t n = 0;
    if (rest[0] == '/' && rest[1] == '/') { /* an authority: empty, localhost or a server */
        const char *host = rest + 2;
        const char *slash = strchr(host, '/');
        const size_t host_length = slash ? (size_t)(slash - host) : strlen(host);
        if (host_length == 0 || (host_length == 9 && starts_with_nocase(host, "localhost"))) {
            rest = host + host_length;
        } else if (style == PATHS_WINDOWS) { /* a share: \\server\share\dir */
            if (size < 3) return false;
            path[n++] = '/';
            path[n++] = '/';
            rest = host;
        } else {
            return false; /* another machine's file: no local path on POSIX */
        }
    }
    if (rest[0] != '/' && n == 0) return false; /* a file URI's path is absolute */
    if (!append_decoded(rest, path, size, &n)) return false;
    if (style == PATHS_WINDOWS) {
        /* "/C:/dir" or "/C|/dir" is the drive path "C:/dir" */
        if (path[0] == '/' && is_letter(path[1]) && (path[2] == ':' || path[2] == '|') &&
            (path[3] == '/' || path[3] == 0)) {
            memmove(path, path + 1, n); /* n characters and the terminating NUL */
            path[1] = ':';
        }
        for (char *c = path; *c; c++)
            if (*c == '/') *c = '\\';
    }
    return true;
}
