// A velocity-level solve like rapier's (TGS-soft style) on the report's pendulums and chain, for
// comparison with SHAKE on lines. Per substep h: v += g h; `iters` Gauss-Seidel sweeps of impulses
// along each stick that aim at the relative velocity -C/h (Baumgarte at full strength, as rapier's
// very stiff joints); x += v h; one bias-free sweep (target 0) to take back the velocity the
// position bias added. No position projection. Scenes (2D, g 9.81, 1/64 s steps):
//  * pendulum 1 m, unit mass, released at 90 and 120 deg: period error against the exact period
//    (elliptic integral) over the first 10 s, energy left after 10 s;
//  * double pendulum, two 1 m links, unit masses, released horizontal: energy after 60 s (largest
//    ratio seen in brackets), as ../../../shared/reference/prototypes/double_pendulum_shake.c;
//  * 100 links of 0.1 m, unit masses, 1000:1 tip: total stretch hanging after 3 s, largest link
//    strain swinging from horizontal over 4 s.
// Build and run: gcc -O2 velocity_level.c -lm -o velocity_level && ./velocity_level
#include <math.h>
#include <stdio.h>
#define MAXN 101
typedef struct { double x, y; } V;
static int N;
static V x[MAXN + 1], v[MAXN + 1];
static double w[MAXN + 1], L;
static const double G = 9.81;
static void init(int n, double len, double angle_deg, double tip) {
  N = n; L = len;
  double a = angle_deg * M_PI / 180;  // from straight down
  for (int i = 0; i <= N; i++) { x[i] = (V){i * L * sin(a), -i * L * cos(a)}; v[i] = (V){0, 0}; w[i] = 1; }
  w[0] = 0; w[N] = 1 / tip;
}
static void sweep(double h, int biased) {
  for (int j = 0; j < N; j++) {
    int a = j, b = j + 1;
    double dx = x[b].x - x[a].x, dy = x[b].y - x[a].y, d = sqrt(dx * dx + dy * dy), nx = dx / d, ny = dy / d;
    double ws = w[a] + w[b];
    if (ws == 0) continue;
    double target = biased ? -(d - L) / h : 0, rel = nx * (v[b].x - v[a].x) + ny * (v[b].y - v[a].y);
    double p = (target - rel) / ws;
    v[a].x -= w[a] * nx * p; v[a].y -= w[a] * ny * p; v[b].x += w[b] * nx * p; v[b].y += w[b] * ny * p;
  }
}
static void step(double dt, int substeps, int iters) {
  double h = dt / substeps;
  for (int s = 0; s < substeps; s++) {
    for (int i = 1; i <= N; i++) v[i].y -= G * h;
    for (int k = 0; k < iters; k++) sweep(h, 1);
    for (int i = 1; i <= N; i++) { x[i].x += v[i].x * h; x[i].y += v[i].y * h; }
    sweep(h, 0);
  }
}
static double energy(void) { double e = 0; for (int i = 1; i <= N; i++) e += 0.5 / w[i] * (v[i].x * v[i].x + v[i].y * v[i].y) + G / w[i] * x[i].y; return e; }
static double exact_period(double amp) {  // T = 4 sqrt(L/g) K(sin(amp/2)), AGM
  double k = sin(amp / 2), a = 1, b = sqrt(1 - k * k);
  for (int i = 0; i < 30; i++) { double t = (a + b) / 2; b = sqrt(a * b); a = t; }
  return 4 * sqrt(1.0 / G) * M_PI / (2 * a);
}
static void pendulum(double deg, int S, int I) {
  init(1, 1.0, deg, 1);
  double e0 = energy(), prev = x[1].x, t = 0, first = -1, last = -1; int crossings = 0;
  for (int s = 0; s < 640; s++) {
    step(1.0 / 64, S, I); t += 1.0 / 64;
    if (prev > 0 && x[1].x <= 0) {  // crossing from right to left: once per period
      double tc = t - 1.0 / 64 * x[1].x / (x[1].x - prev);
      if (first < 0) first = tc; else { last = tc; crossings++; }
    }
    prev = x[1].x;
  }
  double period = (last - first) / crossings, exact = exact_period(deg * M_PI / 180);
  double bottom = -G;  // potential at the bottom, 1 kg, 1 m
  printf("pendulum %3.0f deg  %2d x %d: period error %+8.4f %%, energy kept %.4f\n", deg, S, I, (period / exact - 1) * 100, (energy() - bottom) / (e0 - bottom));
}
static void double_pendulum(int S, int I) {
  init(2, 1.0, 90, 1);
  double e0 = energy(), bottom = -G * (1 + 2), hi = 0;  // both at the bottom: -1 and -2 m
  for (int s = 0; s < 3840; s++) { step(1.0 / 64, S, I); hi = fmax(hi, (energy() - bottom) / (e0 - bottom)); }
  printf("double pendulum %2d x %d: energy after 60 s %.3f (largest %.3f)\n", S, I, (energy() - bottom) / (e0 - bottom), hi);
}
static void chain(int S, int I) {
  init(100, 0.1, 0, 1000);
  for (int s = 0; s < 192; s++) step(1.0 / 64, S, I);
  double len = 0; for (int j = 0; j < N; j++) len += hypot(x[j + 1].x - x[j].x, x[j + 1].y - x[j].y);
  init(100, 0.1, 90, 1000);
  double worst = 0;
  for (int s = 0; s < 256; s++) { step(1.0 / 64, S, I); for (int j = 0; j < N; j++) worst = fmax(worst, hypot(x[j + 1].x - x[j].x, x[j + 1].y - x[j].y) / L - 1); }
  printf("1000:1 chain %2d x %d: hanging total stretch %.3f %%, swinging largest link %.1f %%\n", S, I, (len / (N * 0.1) - 1) * 100, worst * 100);
}
int main(void) {
  int cfg[][2] = {{8, 1}, {4, 4}, {16, 1}, {64, 1}};
  for (int c = 0; c < 4; c++) {
    pendulum(90, cfg[c][0], cfg[c][1]); pendulum(120, cfg[c][0], cfg[c][1]);
    double_pendulum(cfg[c][0], cfg[c][1]); chain(cfg[c][0], cfg[c][1]);
  }
  return 0;
}
