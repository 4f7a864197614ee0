// The element interface: what the assembler, the energies and the analyses need of an
// element, whatever its type. Model keeps one registry of them (ElementList); the loops
// over elements in assembly.cpp, transient.cpp and rigid_rotation.cpp go through it only.
//
// An element connects n_nodes() nodes; its coordinates are the 6 nodal coordinates of
// each of its nodes in order (6 n_nodes(): a frame node [x (3) m, phi (3) rad], an ANCF
// node [r (3) m, r' (3) -]), whatever the element uses of them. Its kernel writes the
// element residual r (6 n_nodes()) and the weighted tangents
//     J = wK dr/dq + wC dr/dq_dot + wM dr/dq_ddot   (row-major, (6 n_nodes())^2)
// into buffers the assembler owns (no allocation in a kernel), every entry of them,
// zeros included: the assembler scatters all entries in a fixed order, the tangent's
// pattern. docs/elements.md describes how to add an element type.
#pragma once

#include "pipeflex/elements/pipe_beam3d.hpp"

#include <Eigen/Core>
#include <memory>
#include <stdexcept>
#include <string>
#include <typeinfo>
#include <utility>
#include <vector>

namespace pipeflex {

struct Model;
struct State;

enum class NodeKind : int { frame = 0, ancf = 1 };

// The weights of a tangent wK dR/dq + wC dR/dq_dot + wM dR/dq_ddot (assemble_csc's sets).
struct TangentWeights {
    double wK = 1.0, wC = 0.0, wM = 0.0;
};

// What an element kernel reads besides its own data.
struct ElementInputs {
    const State& state;
    const LoadState& load;
    // node_motion(phi, phi_dot, phi_ddot) of every frame node of the model, in the
    // residual-only pass of a model with an element whose uses_node_motions() (one
    // evaluation per node for all its elements); null otherwise.
    const NodeMotion<double>* motions;
};

// One kernel call's request and the caller-owned buffers it fills.
struct ElementOutputs {
    int nw = 0;                    // weight sets (0: the residual alone)
    const double* weights = nullptr;  // 3 nw: (wK, wC, wM) of each set
    double* r = nullptr;           // 6 n_nodes() (null: not wanted)
    double* const* J = nullptr;    // nw tangents, row-major (6 n_nodes())^2 each
    // this element's n_stresses() stresses for the geometric part of dr/dq in place of
    // the state's own (the mixed Newton's prediction), or null
    const double* geometric_stresses = nullptr;
};

class Element {
public:
    explicit Element(std::vector<int> nodes) : nodes_(std::move(nodes)) {}
    virtual ~Element() = default;
    // A deep copy (a Model copies its elements).
    virtual std::unique_ptr<Element> clone() const = 0;
    // "pipe element", ...: the messages' name of the type.
    virtual const char* name() const = 0;

    // The nodes it connects, in the order of its coordinates.
    const std::vector<int>& nodes() const { return nodes_; }
    int n_nodes() const { return static_cast<int>(nodes_.size()); }
    // Whether a node of the given kind can carry it.
    virtual bool accepts(NodeKind kind) const = 0;

    // Called by Model::finalize after the generic checks (node indices, kinds): the
    // type's own checks (throw std::invalid_argument) and its stress-free reference.
    virtual void finalize(const Model& model) { (void)model; }

    // Residual and tangents (see ElementOutputs); nw = 0 and r = null: nothing to do.
    virtual void kernel(const ElementInputs& in, const ElementOutputs& out) const = 0;
    virtual bool uses_node_motions() const { return false; }

    // Kinetic [J] and elastic [J] energy at the state.
    virtual void energies(const State& state, double* kinetic, double* elastic) const = 0;
    // Adds the potential of gravity g [m/s^2] (the load's, times its factor) [J] to *V,
    // term by term (the model's sum is then one running sum over all elements).
    virtual void add_gravity_potential(const State& state, const Vec3<double>& g, double* V) const = 0;
    // The mass per unit length [kg/m] its gravity load acts on (0: none). A distributed
    // load q [N/m] on the element is carried by the same consistent (shape-function
    // weighted) gravity term, the kernel's gravity raised by q / line_mass().
    virtual double line_mass() const { return 0.0; }
    // Subtracts v . f_fluid [W] (the power of the flow-dependent forces on the structure)
    // from *P, term by term; elements without flow leave it. motions: node_motion of every
    // frame node at the state (node_motions), or null (evaluated by the element).
    virtual void add_fluid_power(const State& state, const LoadState& load, const NodeMotion<double>* motions,
                                 double* P) const {
        (void)state, (void)load, (void)motions, (void)P;
    }
    // Whether it has damping forces (structural or viscous damping, dashpots): only then
    // can add_damping_power add anything.
    virtual bool damped() const { return false; }
    // Adds v . f_d [W] (>= 0) to *P: the power its damping forces f_d (the velocity-
    // dependent dissipative part of its residual) take out of the motion.
    virtual void add_damping_power(const State& state, double* P) const { (void)state, (void)P; }

    // The stresses of the mixed Newton (the static Newton of pipe elements): how many
    // (0: none), and their prediction along the full-coordinate increment dq.
    virtual int n_stresses() const { return 0; }
    virtual void predicted_stresses(const State& state, const Eigen::VectorXd& dq, double* sigma) const {
        (void)state, (void)dq, (void)sigma;
    }

    // Prestress (geometric) stiffness of the strains that dq produces to first order,
    // (6 n_nodes())^2 row-major. prestress_unavailable(): null if the element has one,
    // else why not (assemble_geometric throws it).
    virtual const char* prestress_unavailable() const {
        return "the small-deformation prestress stiffness is defined for ANCF Model A elements only "
               "(use the steady-state linearisation)";
    }
    virtual void prestress_stiffness(const State& state, const Eigen::VectorXd& dq, double* G) const {
        (void)state, (void)dq, (void)G;
    }

    // Whether it can take part in a co-rotating frame (ANCF hub models: its kernel then
    // adds the frame's fictitious forces, LoadState::frame_rate ...).
    virtual bool in_co_rotating_frame() const { return false; }

    // The 6 per node of x (q, v or a of a state, 6 per model node) at its nodes: out has
    // 6 n_nodes() entries.
    void gather(const Eigen::VectorXd& x, double* out) const {
        const int* n = nodes_.data();
        for (std::size_t a = 0, na = nodes_.size(); a < na; ++a) {
            const double* xa = x.data() + 6 * n[a];
            for (int i = 0; i < 6; ++i) out[6 * a + i] = xa[i];
        }
    }

protected:
    Element(const Element&) = default;
    Element& operator=(const Element&) = default;

private:
    std::vector<int> nodes_;
};

// The model's elements (owning, in the order they were added; copies are deep).
class ElementList {
public:
    ElementList() = default;
    ElementList(const ElementList& other) { *this = other; }
    ElementList& operator=(const ElementList& other) {
        if (this == &other) return *this;
        items_.clear();
        items_.reserve(other.items_.size());
        for (const auto& e : other.items_) items_.push_back(e->clone());
        return *this;
    }
    ElementList(ElementList&&) noexcept = default;
    ElementList& operator=(ElementList&&) noexcept = default;

    void add(std::unique_ptr<Element> e) { items_.push_back(std::move(e)); }
    void reserve(std::size_t n) { items_.reserve(n); }
    std::size_t size() const { return items_.size(); }
    bool empty() const { return items_.empty(); }
    const Element& operator[](std::size_t i) const { return *items_[i]; }
    Element& operator[](std::size_t i) { return *items_[i]; }
    auto begin() const { return items_.begin(); }
    auto end() const { return items_.end(); }

    // Type-specific access, for the bindings that return an element type's own data
    // (Model.pipe(k), Model.ancf_nodes(k)): the number of elements of type E, and the
    // k-th of them (a dynamic_cast; null if there are not k + 1).
    template <class E> int count() const {
        int n = 0;
        for (const auto& e : items_) n += dynamic_cast<const E*>(e.get()) != nullptr;
        return n;
    }
    template <class E> const E* nth(int k) const {
        for (const auto& e : items_)
            if (const auto* x = dynamic_cast<const E*>(e.get()); x != nullptr && k-- == 0) return x;
        return nullptr;
    }

private:
    std::vector<std::unique_ptr<Element>> items_;
};

}  // namespace pipeflex
