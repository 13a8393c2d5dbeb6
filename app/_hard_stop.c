/* A SIGINT/SIGTERM handler for the time Python cannot act: a long PETSc call (a MUMPS
 * factorization, a solve) holds the GIL, so the run's watchdog thread cannot write the
 * run's status before mpiexec kills the ranks (Open MPI: SIGKILL 1 s after the SIGTERM it
 * forwards). While armed, the handler writes the prepared summary, prints the prepared
 * line on stderr and exits with 130 (SIGINT) or 143 (SIGTERM). The summary is either the
 * whole file (through a temporary file and a rename) or, for a summary that grows step by
 * step (app/output/append.py), its new tail written in place at a byte offset. Up to
 * MORE further files are written whole after it, each with a line printed after the
 * prepared one (`hard_stop_add`: a study's own summary.json, app/studies/batch_status.py;
 * a sweep's sweep.csv and its `sweep:` line, app/studies/sweep.py). Only async-signal-safe
 * calls. Loaded through ctypes (app/hard_stop.py).
 * `hard_stop_arm_exit` arms it with no file to write: the job's end, once every output is
 * written (app/output/late_signals.py), where the ranks wait in MPI_Finalize;
 * `hard_stop_rearm` installs it again after PetscFinalize reset SIGTERM.
 */
#include <fcntl.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define SLOTS 2 /* 0: SIGINT, 1: SIGTERM */

static char *g_text[SLOTS], *g_line[SLOTS];
static size_t g_text_len[SLOTS], g_line_len[SLOTS];
static char *g_tmp, *g_path;
static long long g_offset = -1; /* >= 0: write the text in place at this offset */
#define MORE 4 /* further files (and lines) an armed signal writes */
static char *g_xtext[MORE][SLOTS], *g_xline[MORE][SLOTS], *g_xtmp[MORE], *g_xpath[MORE];
static size_t g_xtext_len[MORE][SLOTS], g_xline_len[MORE][SLOTS];
static int g_more = 0; /* how many are set */
static struct sigaction g_old[SLOTS];
/* 0 not armed, 1 armed, 2 a handler is writing (it ends the process), 3 being disarmed.
 * Changed only by atomic compare-and-swap (lock-free, so async-signal-safe): disarm runs
 * on whichever thread ends the job, the handler on whichever thread the signal reaches,
 * and `armed`'s own disarm may run at the same time (ctypes calls drop the GIL). Before,
 * two threads disarming at once freed the texts twice ("double free or corruption"), and a
 * handler could write texts another thread was freeing. */
static int g_armed = 0;
#define ARMED 1
#define WRITING 2
#define DISARMING 3

static int take(int from, int to) {
    int expected = from;
    return __atomic_compare_exchange_n(&g_armed, &expected, to, 0, __ATOMIC_SEQ_CST,
                                       __ATOMIC_SEQ_CST);
}

static int state(void) { return __atomic_load_n(&g_armed, __ATOMIC_SEQ_CST); }
static int g_stay = 0; /* hard_stop_arm_exit on a rank other than 0: return, do not exit */

static void write_all(int fd, const char *p, size_t n) {
    while (n > 0) {
        ssize_t k = write(fd, p, n);
        if (k <= 0) return;
        p += k;
        n -= (size_t)k;
    }
}

static void patch_in_place(int slot) {
    int fd = open(g_path, O_WRONLY);
    size_t done = 0;
    if (fd < 0) return;
    while (done < g_text_len[slot]) {
        ssize_t k = pwrite(fd, g_text[slot] + done, g_text_len[slot] - done,
                           (off_t)(g_offset + (long long)done));
        if (k <= 0) break;
        done += (size_t)k;
    }
    fsync(fd);
    close(fd);
}

static void replace_whole(const char *tmp, const char *path, const char *text, size_t n) {
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) return;
    write_all(fd, text, n);
    if (fsync(fd) == 0 && close(fd) == 0) rename(tmp, path);
    else unlink(tmp);
}

static void on_signal(int sig) {
    int slot = sig == SIGTERM ? 1 : 0;
    if (g_stay) return;
    if (!take(ARMED, WRITING)) {
        if (state() == WRITING)
            for (;;) pause(); /* another thread's handler writes and exits the process */
        /* being disarmed (the texts may be freed): the handler found at arm time takes it */
        sigaction(sig, &g_old[slot], NULL);
        raise(sig); /* (blocked here: delivered once this handler returns) */
        return;
    }
    if (!g_path) {
        /* armed by hard_stop_arm_exit: no file */
    } else if (g_offset >= 0) patch_in_place(slot);
    else replace_whole(g_tmp, g_path, g_text[slot], g_text_len[slot]);
    for (int i = 0; i < g_more; i++)
        if (g_xpath[i]) replace_whole(g_xtmp[i], g_xpath[i], g_xtext[i][slot], g_xtext_len[i][slot]);
    write_all(2, g_line[slot], g_line_len[slot]);
    for (int i = 0; i < g_more; i++) write_all(2, g_xline[i][slot], g_xline_len[i][slot]);
    _exit(sig == SIGTERM ? 143 : 130);
}

static char *copy(const char *s, size_t n) {
    char *p = malloc(n + 1);
    if (p) {
        memcpy(p, s, n);
        p[n] = '\0';
    }
    return p;
}

/* Free extra file i's texts, lines and paths. */
static void release_one(int i) {
    for (int k = 0; k < SLOTS; k++) {
        free(g_xtext[i][k]);
        free(g_xline[i][k]);
        g_xtext[i][k] = g_xline[i][k] = NULL;
    }
    free(g_xtmp[i]);
    free(g_xpath[i]);
    g_xtmp[i] = g_xpath[i] = NULL;
}

static void release_extra(void) {
    for (int i = 0; i < MORE; i++)
        release_one(i);
    g_more = 0;
}

static void release(void) {
    for (int i = 0; i < SLOTS; i++) {
        free(g_text[i]);
        free(g_line[i]);
        g_text[i] = g_line[i] = NULL;
    }
    free(g_tmp);
    free(g_path);
    g_tmp = g_path = NULL;
    release_extra();
}

/* Install on_signal for SIGINT and SIGTERM, keeping the handlers found (g_old), and mark
 * armed. Returns 0, or -1 (nothing armed, the texts freed) if sigaction failed. */
static int install(void) {
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigfillset(&sa.sa_mask);
    if (sigaction(SIGINT, &sa, &g_old[0]) != 0) {
        release();
        return -1;
    }
    if (sigaction(SIGTERM, &sa, &g_old[1]) != 0) {
        sigaction(SIGINT, &g_old[0], NULL);
        release();
        return -1;
    }
    __atomic_store_n(&g_armed, ARMED, __ATOMIC_SEQ_CST);
    return 0;
}

/* Before hard_stop_arm: one more file the handler writes whole (texts for SIGINT and
 * SIGTERM; path NULL: none) and lines it prints after the prepared one (either may be
 * empty); disarming forgets them. Returns 0, or -1 (not added) if armed, MORE are set
 * already or out of memory. */
int hard_stop_add(const char *tmp, const char *path, const char *text_int, size_t n_int,
                  const char *text_term, size_t n_term, const char *line_int,
                  const char *line_term) {
    int i = g_more;
    if (state() || i >= MORE) return -1;
    g_xtmp[i] = path ? copy(tmp, strlen(tmp)) : NULL;
    g_xpath[i] = path ? copy(path, strlen(path)) : NULL;
    g_xtext[i][0] = copy(text_int, n_int);
    g_xtext[i][1] = copy(text_term, n_term);
    g_xline[i][0] = copy(line_int, strlen(line_int));
    g_xline[i][1] = copy(line_term, strlen(line_term));
    if ((path && (!g_xtmp[i] || !g_xpath[i])) || !g_xtext[i][0] || !g_xtext[i][1] ||
        !g_xline[i][0] || !g_xline[i][1]) {
        release_one(i);
        return -1;
    }
    g_xtext_len[i][0] = n_int;
    g_xtext_len[i][1] = n_term;
    g_xline_len[i][0] = strlen(line_int);
    g_xline_len[i][1] = strlen(line_term);
    g_more = i + 1;
    return 0;
}

/* The one further file of builds before hard_stop_add (no line): hard_stop_add. */
int hard_stop_extra(const char *tmp, const char *path, const char *text_int, size_t n_int,
                    const char *text_term, size_t n_term) {
    return hard_stop_add(tmp, path, text_int, n_int, text_term, n_term, "", "");
}

/* Arm: texts[i]/lines[i] for SIGINT (0) and SIGTERM (1), the summary's path, its
 * temporary path and the offset of an in-place write (-1: the whole file). Returns 0, or
 * -1 (nothing armed) if memory or sigaction failed. */
int hard_stop_arm(const char *tmp, const char *path, long long offset,
                  const char *text_int, size_t n_int,
                  const char *text_term, size_t n_term, const char *line_int,
                  const char *line_term) {
    if (state()) return -1;
    g_tmp = copy(tmp, strlen(tmp));
    g_path = copy(path, strlen(path));
    g_text[0] = copy(text_int, n_int);
    g_text[1] = copy(text_term, n_term);
    g_line[0] = copy(line_int, strlen(line_int));
    g_line[1] = copy(line_term, strlen(line_term));
    if (!g_tmp || !g_path || !g_text[0] || !g_text[1] || !g_line[0] || !g_line[1]) {
        release();
        return -1;
    }
    g_offset = offset;
    g_text_len[0] = n_int;
    g_text_len[1] = n_term;
    g_line_len[0] = strlen(line_int);
    g_line_len[1] = strlen(line_term);
    return install();
}

/* Arm with no file: on SIGINT / SIGTERM print line_int / line_term (either may be empty)
 * and exit with 130 / 143; with stay, do nothing: a rank other than 0 waits for mpiexec's
 * SIGKILL, which it sends every rank as soon as one rank has ended, so that rank 0 has
 * printed its line first. Returns 0, or -1 (nothing armed). */
int hard_stop_arm_exit(const char *line_int, const char *line_term, int stay) {
    if (state()) return -1;
    release_extra(); /* the job's end: a study's summary is written, never overwritten */
    g_line[0] = copy(line_int, strlen(line_int));
    g_line[1] = copy(line_term, strlen(line_term));
    g_text[0] = copy("", 0);
    g_text[1] = copy("", 0);
    if (!g_line[0] || !g_line[1] || !g_text[0] || !g_text[1]) {
        release();
        return -1;
    }
    g_tmp = g_path = NULL;
    g_offset = -1;
    g_stay = stay;
    g_text_len[0] = g_text_len[1] = 0;
    g_line_len[0] = strlen(line_int);
    g_line_len[1] = strlen(line_term);
    return install();
}

/* Install the handler armed before again (PetscFinalize puts SIGTERM back to its default
 * before it calls MPI_Finalize: registered with PetscRegisterFinalize, which it calls in
 * between). Returns 0 (a PetscErrorCode). */
int hard_stop_rearm(void) {
    struct sigaction sa;
    if (state() != ARMED) return 0;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigfillset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    return 0;
}

/* Disarm: put back the handlers found at arm time (Python's), free the texts. */
void hard_stop_disarm(void) {
    if (!take(ARMED, DISARMING)) {
        if (state() == WRITING)
            for (;;) pause(); /* a handler is ending the process: its texts must stay */
        return; /* not armed, or another thread disarms it */
    }
    sigaction(SIGINT, &g_old[0], NULL);
    sigaction(SIGTERM, &g_old[1], NULL);
    g_stay = 0;
    release();
    __atomic_store_n(&g_armed, 0, __ATOMIC_SEQ_CST);
}
