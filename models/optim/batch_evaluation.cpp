// A round's points as a batch over the run's workers (see batch_evaluation.h).
#include "models/optim/batch_evaluation.h"

#include <limits>
#include <numeric>

#include "models/io/byte_record.h"
#include "models/sim/batch_workers.h"
#include "models/sim/compute_device.h"
#include "runtime/cuda_runtime.h"
#include "runtime/errors.h"

namespace ssc {
namespace {

PhysicalParameters with_values(PhysicalParameters p, const std::vector<std::string>& names, const Eigen::VectorXd& x) {
  for (size_t i = 0; i < names.size(); ++i) set_parameter(p, names[i], x[i]);
  return p;
}

// Points [share.begin, share.end) on the share's worker, with the drop-and-rerun of failures.
std::vector<PointEvaluation> evaluate_share(BatchSimulations& sims, const BatchShare& share,
                                            const SurfaceConstraintCost& cost, const PhysicalParameters& base,
                                            const std::vector<std::string>& names,
                                            const std::vector<Eigen::VectorXd>& points, bool gradient,
                                            const SurfaceResiduals* residuals,
                                            const std::function<void(int, int)>& on_step) {
  const Problem& problem = sims.problem();
  GradientOptions options;
  options.gradient = gradient && !residuals;
  if (share.reports) options.on_step = on_step;
  const int n = share.end - share.begin;
  std::vector<PointEvaluation> out(static_cast<size_t>(n));
  auto point = [&](int i) { return points[size_t(share.begin + i)]; };
  // One result per batch item; item i is the share's point pending[i] (the first beyond `pending`).
  auto run = [&](Simulation& sim, const std::vector<int>& pending) {
    if (!residuals) return evaluate_cost_gradient(sim, cost, problem.frames, options);
    std::vector<ResidualVector> r(size_t(sim.batch()));
    for (ResidualVector& v : r) v.r.resize(residuals->size()), v.matched.resize(size_t(residuals->size()));
    std::vector<int> steps;
    for (const ObservedFrame& f : problem.frames) steps.push_back(f.step);
    const std::vector<CostGradient> c = evaluate_trajectory_gradient(
        sim, steps,
        [&](size_t f, int item, const double* u, const double* band, double*, double*) {
          return residuals->frame(f, u, band, &r[size_t(item)]);
        },
        options);
    for (size_t i = 0; i < pending.size(); ++i) out[size_t(pending[i])].residuals = std::move(r[i]);
    return c;
  };
  // Points `pending` as one batch, failed ones dropped and the rest run again.
  auto run_points = [&](std::vector<int> pending) {
    while (!pending.empty()) {
      const int m = int(pending.size());
      std::vector<int> named;
      try {
        Simulation& sim = sims.batch(share.worker, share.device, m);
        // Places beyond m (a larger batch kept on the GPU) run copies of the first point.
        for (int i = 0; i < sim.batch(); ++i)
          sim.set_parameters(i, with_values(base, names, point(pending[size_t(i < m ? i : 0)])));
        const std::vector<CostGradient> r = run(sim, pending);
        for (int i = 0; i < m; ++i) out[size_t(pending[size_t(i)])].value = r[size_t(i)];
        return;
      } catch (const SimulationError& e) {
        sims.forget(share.worker);
        for (int item : e.items) named.push_back(pending[size_t(item < m ? item : 0)]);
        if (named.empty() && m == 1) named.push_back(pending[0]);
        if (named.empty()) break;
        for (int s : named) {
          out[size_t(s)].ok = false;
          out[size_t(s)].failure = e.what();
        }
      }
      std::vector<int> rest;
      for (int s : pending)
        if (out[size_t(s)].ok) rest.push_back(s);
      pending = rest;
    }
    for (int s : pending) {
      try {
        const std::unique_ptr<Simulation> sim = sims.make(share.device, 1);
        sim->set_parameters(0, with_values(base, names, point(s)));
        out[size_t(s)].value = run(*sim, {s})[0];
      } catch (const SimulationError& e) {
        out[size_t(s)].ok = false;
        out[size_t(s)].failure = e.what();
      }
    }
  };
  const int limit = sims.batch_limit(share.worker, share.device);
  const int turns = n <= limit ? 1 : (n + limit - 1) / limit;
  for (int t = 0; t < turns; ++t) {
    if (share.reports && on_step && turns > 1)
      options.on_step = [&, t](int done, int total) { on_step(t * total + done, turns * total); };
    const int first = t * (n / turns) + std::min(t, n % turns);  // turns of equal size, the first n % turns one larger
    std::vector<int> turn(static_cast<size_t>(n / turns + (t < n % turns ? 1 : 0)));
    std::iota(turn.begin(), turn.end(), first);
    run_points(turn);
  }
  return out;
}

void put_gradient(ByteWriter& w, const ParameterGradient& g) {
  for (double x : {g.youngs_modulus, g.poisson_ratio, g.density, g.mass_damping, g.stiffness_damping}) w.put(x);
  for (const Eigen::Vector3d* v : {&g.gravity, &g.linear_velocity, &g.angular_velocity})
    for (int i = 0; i < 3; ++i) w.put((*v)[i]);
  w.put<long long>((long long)g.plane_normal.size());
  for (const Eigen::Vector3d& v : g.plane_normal)
    for (int i = 0; i < 3; ++i) w.put(v[i]);
  w.put_vector(g.plane_height);
  w.put<long long>((long long)g.input.size());
  for (const auto& [name, values] : g.input) {
    w.put_string(name);
    w.put_vector(values);
  }
}

ParameterGradient get_gradient(ByteReader& r) {
  ParameterGradient g;
  for (double* x : {&g.youngs_modulus, &g.poisson_ratio, &g.density, &g.mass_damping, &g.stiffness_damping})
    *x = r.get<double>();
  for (Eigen::Vector3d* v : {&g.gravity, &g.linear_velocity, &g.angular_velocity})
    for (int i = 0; i < 3; ++i) (*v)[i] = r.get<double>();
  g.plane_normal.resize(size_t(r.get<long long>()));
  for (Eigen::Vector3d& v : g.plane_normal)
    for (int i = 0; i < 3; ++i) v[i] = r.get<double>();
  g.plane_height = r.get_vector<double>();
  const long long inputs = r.get<long long>();
  for (long long k = 0; k < inputs; ++k) {
    std::string name = r.get_string();
    g.input[name] = r.get_vector<double>();
  }
  return g;
}

}  // namespace

BatchSimulations::BatchSimulations(const Problem& problem, std::string device)
    : problem_(problem), device_(std::move(device)) {}

BatchSimulations::~BatchSimulations() = default;

void BatchSimulations::reserve_workers(int count) {
  if (int(batches_.size()) < count) batches_.resize(size_t(count)), limits_.resize(size_t(count), 0);
}

int BatchSimulations::batch_limit(int worker, const std::string& device) {
  if (!runs_on_gpu(device)) return std::numeric_limits<int>::max();
  int& limit = limits_.at(size_t(worker));
  if (limit == 0) {
    std::unique_ptr<Simulation>& b = batches_.at(size_t(worker));
    if (!b) b = make(device, 1);
    limit = b->gpu()->resident_items();
  }
  return limit;
}

Simulation& BatchSimulations::batch(int worker, const std::string& device, int n) {
  std::unique_ptr<Simulation>& b = batches_.at(size_t(worker));
  if (!b || b->batch() < n || (b->batch() != n && !runs_on_gpu(device))) {
    b.reset();
    b = make(device, n);
  }
  return *b;
}

void BatchSimulations::forget(int worker) { batches_.at(size_t(worker)).reset(); }

std::unique_ptr<Simulation> BatchSimulations::make(const std::string& device, int n) const {
  auto sim = std::make_unique<Simulation>(problem_.scene, problem_.grid, n, true);
  place_on(*sim, device);
  return sim;
}

std::vector<PointEvaluation> evaluate_batch(BatchSimulations& sims, const SurfaceConstraintCost& cost,
                                            const PhysicalParameters& base, const std::vector<std::string>& names,
                                            const std::vector<Eigen::VectorXd>& points, bool gradient,
                                            const SurfaceResiduals* residuals,
                                            const std::function<void(int, int)>& on_step) {
  const int n = int(points.size());
  const std::vector<BatchShare> shares = this_rank_shares(n, sims.device());
  for (const BatchShare& s : shares) sims.reserve_workers(s.worker + 1);
  if (shares.size() == 1 && shares[0].begin == 0 && shares[0].end == n)  // one worker: no copies
    return evaluate_share(sims, shares[0], cost, base, names, points, gradient, residuals, on_step);
  const std::vector<std::string> bytes = run_shared(n, sims.device(), [&](const BatchShare& share) {
    std::vector<std::string> out;
    for (const PointEvaluation& e : evaluate_share(sims, share, cost, base, names, points, gradient, residuals, on_step))
      out.push_back(encode_point(e));
    return out;
  });
  std::vector<PointEvaluation> out;
  for (const std::string& b : bytes) out.push_back(decode_point(b));
  return out;
}

std::string encode_point(const PointEvaluation& e) {
  ByteWriter w;
  w.put(char(e.ok));
  w.put_string(e.failure);
  w.put(e.value.cost);
  w.put_vector(e.value.frames);
  put_gradient(w, e.value.gradient);
  w.put<long long>((long long)e.residuals.r.size());
  for (Eigen::Index i = 0; i < e.residuals.r.size(); ++i) w.put(e.residuals.r[i]);
  w.put_vector(e.residuals.matched);
  return w.bytes();
}

PointEvaluation decode_point(const std::string& bytes) {
  ByteReader r(bytes);
  PointEvaluation e;
  e.ok = r.get<char>() != 0;
  e.failure = r.get_string();
  e.value.cost = r.get<double>();
  e.value.frames = r.get_vector<FrameCost>();
  e.value.gradient = get_gradient(r);
  e.residuals.r.resize(Eigen::Index(r.get<long long>()));
  for (Eigen::Index i = 0; i < e.residuals.r.size(); ++i) e.residuals.r[i] = r.get<double>();
  e.residuals.matched = r.get_vector<char>();
  if (!r.at_end()) throw std::runtime_error("a point's evaluation record has bytes left over");
  return e;
}

}  // namespace ssc
