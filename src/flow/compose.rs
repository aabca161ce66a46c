use super::{CompositionTable, EXACT, Flow, FlowStats, Ledger, Multipliers};
use crate::error::StepError;
use crate::real::Real;
use crate::vector::Vector;

/// `a` for `h`, then `b` for `h`: the Lie–Trotter splitting, order 1 (GNI §II.5).
#[derive(Debug, Clone)]
pub struct Then<V: Vector, A, B> {
    a: A,
    b: B,
    backup: Backup<V>,
}

impl<V: Vector, A, B> Then<V, A, B> {
    /// `b(h) ∘ a(h)`.
    pub fn new(a: A, b: B) -> Self {
        Self {
            a,
            b,
            backup: Backup::default(),
        }
    }
}

impl<V: Vector, A: Flow<V>, B: Flow<V>> Flow<V> for Then<V, A, B> {
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    #[inline]
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let guard = self.b.is_fallible();
        let start = *ledger;
        self.backup
            .run(guard, x, |x| {
                self.a.step_at(ledger, h, x)?;
                self.b.step_at(ledger, h, x)
            })
            .inspect_err(|_| *ledger = start)
    }
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.a.save_memory(out);
        self.b.save_memory(out);
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.a.restore_memory(from);
        self.b.restore_memory(from);
    }
    fn is_fallible(&self) -> bool {
        self.a.is_fallible() || self.b.is_fallible()
    }
    fn dissipates(&self) -> bool {
        self.a.dissipates() || self.b.dissipates()
    }
    fn order(&self) -> u32 {
        if self.a.order() == EXACT && self.b.order() == EXACT {
            1
        } else {
            self.a.order().min(self.b.order()).min(1)
        }
    }
    fn is_symmetric(&self) -> bool {
        false
    }
    fn prepare(&mut self, x: &V) {
        self.backup.prepare(x);
        self.a.prepare(x);
        self.b.prepare(x);
    }
    fn stats(&self) -> FlowStats {
        self.a.stats() + self.b.stats()
    }
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.b.multipliers().or_else(|| self.a.multipliers())
    }
    fn is_kick(&self) -> bool {
        self.a.is_kick() && self.b.is_kick()
    }
}

/// Strang splitting `a(h/2) ∘ b(h) ∘ a(h/2)`: order 2 and symmetric when `a` and `b` are
/// symmetric (Strang 1968; GNI §II.5). With `a` a kick and `b` a drift this is Störmer–Verlet.
#[derive(Debug, Clone)]
pub struct Strang<V: Vector, A, B> {
    a: A,
    b: B,
    backup: Backup<V>,
    /// `D a(h/2) v` between the two tangent maps of the lead (only when `a` is a kick).
    tangent: Option<V>,
}

impl<V: Vector, A, B> Strang<V, A, B> {
    /// `a(h/2) ∘ b(h) ∘ a(h/2)`.
    pub fn new(a: A, b: B) -> Self {
        Self {
            a,
            b,
            backup: Backup::default(),
            tangent: None,
        }
    }
}

impl<V: Vector, A: Flow<V>, B: Flow<V>> Strang<V, A, B> {
    /// `a(h/2)`, `b(h)`, and with `tail` the second `a(h/2)`; the state and the ledger are
    /// restored if a sub-flow after the first fails (the first leaves them as they were).
    #[inline(always)]
    fn run(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
        tail: bool,
    ) -> Result<(), StepError> {
        let half = h * V::Real::lit(0.5);
        let guard = self.b.is_fallible() || (tail && self.a.is_fallible());
        let start = *ledger;
        self.backup
            .run(guard, x, |x| {
                self.a.step_at(ledger, half, x)?;
                self.b.step_at(ledger, h, x)?;
                if tail {
                    self.a.step_at(ledger, half, x)?;
                }
                Ok(())
            })
            .inspect_err(|_| *ledger = start)
    }
}

impl<V: Vector, A: Flow<V>, B: Flow<V>> Flow<V> for Strang<V, A, B> {
    #[inline]
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    #[inline]
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        self.run(ledger, h, x, true)
    }
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.a.save_memory(out);
        self.b.save_memory(out);
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.a.restore_memory(from);
        self.b.restore_memory(from);
    }
    fn is_fallible(&self) -> bool {
        self.a.is_fallible() || self.b.is_fallible()
    }
    fn dissipates(&self) -> bool {
        self.a.dissipates() || self.b.dissipates()
    }
    fn order(&self) -> u32 {
        if self.is_symmetric() {
            self.a.order().min(self.b.order()).min(2)
        } else {
            self.a.order().min(self.b.order()).min(1)
        }
    }
    fn is_symmetric(&self) -> bool {
        self.a.is_symmetric() && self.b.is_symmetric()
    }
    fn prepare(&mut self, x: &V) {
        self.backup.prepare(x);
        if self.a.is_kick() && self.tangent.as_ref().is_none_or(|t| t.len() != x.len()) {
            self.tangent = Some(x.zeros_like());
        }
        self.a.prepare(x);
        self.b.prepare(x);
    }
    fn stats(&self) -> FlowStats {
        self.a.stats() + self.b.stats()
    }
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.b.multipliers().or_else(|| self.a.multipliers())
    }
    fn is_kick(&self) -> bool {
        self.a.is_kick() && self.b.is_kick()
    }
    /// Of two kicks (the positions frozen through the step): both halves of `a` are the same
    /// map at the same positions, so `DΦ v = D a · D b · D a v`, each part's tangent of its
    /// last step; otherwise not formed (`false`).
    fn tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        if !(self.a.is_kick() && self.b.is_kick()) {
            return false;
        }
        let scratch = self.tangent.get_or_insert_with(|| v.zeros_like());
        if !(self.a.tangent_apply(v, out) && self.b.tangent_apply(out, scratch)) {
            return false;
        }
        self.a.tangent_apply(scratch, out)
    }
    /// With `a` a [kick](Flow::is_kick) the lead is `b(h) ∘ a(h/2)` and the tail the second
    /// `a(h/2)`; otherwise the whole step, as the default.
    #[inline]
    fn step_lead(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let tail = !self.a.is_kick();
        self.run(ledger, h, x, tail)
    }
    #[inline]
    fn step_tail(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        if !self.a.is_kick() {
            return Ok(());
        }
        // One sub-flow: on failure it leaves the state and the ledger as they were.
        self.a.step_at(ledger, h * V::Real::lit(0.5), x)
    }
    /// A kick outside (it maps momentum directions to momentum directions), between two of its
    /// half-steps a flow, both affine along them.
    fn is_affine_in_momenta(&self) -> bool {
        self.a.is_kick() && self.a.is_affine_in_momenta() && self.b.is_affine_in_momenta()
    }
    /// The lead `b(h) ∘ a(h/2)` (or, without a kick outside, the whole step) is affine along
    /// momentum directions under the same condition as the whole step.
    fn lead_is_affine_in_momenta(&self) -> bool {
        self.is_affine_in_momenta()
    }
    /// `D b(h) · D a(h/2) v`, each at the point of its last step (the lead's), when `a` is a
    /// kick and both apply their tangent maps ([`Flow::tangent_apply`]).
    fn lead_tangent_apply(&mut self, v: &V, out: &mut V) -> bool {
        if !self.a.is_kick() {
            return false;
        }
        let scratch = self.tangent.get_or_insert_with(|| v.zeros_like());
        self.a.tangent_apply(v, scratch) && self.b.tangent_apply(scratch, out)
    }
}

/// Symmetric composition `Φ_{γ_s h} ∘ … ∘ Φ_{γ_1 h}` of a symmetric flow `Φ` with the coefficients
/// of a [`CompositionTable`]; raises order 2 to the table's order (Yoshida 1990; McLachlan 1995;
/// GNI §V.3). If a stage fails, the state is restored to its value before the step.
///
/// Every table above order 2 has negative coefficients. On a flow that
/// [dissipates](Flow::dissipates) a negative sub-step runs the damping backwards and adds
/// energy, which blows up when the damping is stiff; such a composition returns
/// [`StepError::BackwardDissipation`] (before touching the state) unless
/// [`allow_backward_dissipation`](Self::allow_backward_dissipation) was called. Positive-weight
/// alternatives: [`Strang`] with the exact damping flow as one of its parts (order 2), or complex
/// coefficients with positive real part (Blanes, Casas & Murua, arXiv:1102.1622; not provided).
#[derive(Debug, Clone)]
pub struct Composition<V: Vector, F> {
    inner: F,
    table: &'static CompositionTable,
    backup: Backup<V>,
    allow_backward_dissipation: bool,
}

impl<V: Vector, F> Composition<V, F> {
    /// Composes `inner` with `table`.
    pub fn new(inner: F, table: &'static CompositionTable) -> Self {
        Self {
            inner,
            table,
            backup: Backup::default(),
            allow_backward_dissipation: false,
        }
    }

    /// Runs the composition even on a dissipative flow, accepting that its negative sub-steps
    /// run the dissipation backwards (stable only for weak damping and small steps).
    pub fn allow_backward_dissipation(mut self) -> Self {
        self.allow_backward_dissipation = true;
        self
    }

    /// The coefficient table.
    pub fn table(&self) -> &'static CompositionTable {
        self.table
    }

    /// The composed flow.
    pub fn inner(&self) -> &F {
        &self.inner
    }
}

impl<V: Vector, F: Flow<V>> Flow<V> for Composition<V, F> {
    #[inline]
    fn step(&mut self, h: V::Real, x: &mut V) -> Result<(), StepError> {
        self.step_at(&mut Ledger::default(), h, x)
    }
    #[inline]
    fn step_at(
        &mut self,
        ledger: &mut Ledger<V::Real>,
        h: V::Real,
        x: &mut V,
    ) -> Result<(), StepError> {
        let table = self.table;
        if !self.allow_backward_dissipation && self.inner.dissipates() && table.has_negative_steps()
        {
            let stage = (0..table.stages)
                .find(|&i| table.gamma(i) < 0.0)
                .unwrap_or(0);
            return Err(StepError::BackwardDissipation {
                table: table.name,
                stage,
                gamma: table.gamma(stage),
            });
        }
        // A flow whose stages run atomically (the fused projection) restores the state itself.
        let guard = self.inner.is_fallible() && !self.inner.step_table_is_atomic();
        let start = *ledger;
        self.backup
            .run(guard, x, |x| self.inner.step_table(ledger, h, table, x))
            .inspect_err(|_| *ledger = start)
    }
    fn save_memory(&mut self, out: &mut Vec<V::Real>) {
        self.inner.save_memory(out);
    }
    fn restore_memory(&mut self, from: &mut &[V::Real]) {
        self.inner.restore_memory(from);
    }
    fn is_fallible(&self) -> bool {
        self.inner.is_fallible()
    }
    fn dissipates(&self) -> bool {
        self.inner.dissipates()
    }
    fn order(&self) -> u32 {
        let p = self.inner.order();
        if self.inner.is_symmetric() && p >= 2 {
            p.max(self.table.order)
        } else {
            p.min(1)
        }
    }
    fn is_symmetric(&self) -> bool {
        self.inner.is_symmetric()
    }
    fn prepare(&mut self, x: &V) {
        self.backup.prepare(x);
        self.inner.prepare(x);
    }
    fn stats(&self) -> FlowStats {
        self.inner.stats()
    }
    fn multipliers(&self) -> Option<Multipliers<'_, V::Real>> {
        self.inner.multipliers()
    }
    fn is_kick(&self) -> bool {
        self.inner.is_kick()
    }
}

/// A copy of the state taken before a multi-stage step, restored if a stage fails, so that
/// compositions keep the [`Flow`] contract (state unchanged on error).
#[derive(Debug, Clone)]
struct Backup<V>(Option<V>);

impl<V> Default for Backup<V> {
    fn default() -> Self {
        Self(None)
    }
}

impl<V: Vector> Backup<V> {
    fn prepare(&mut self, x: &V) {
        if self.0.as_ref().is_none_or(|b| b.len() != x.len()) {
            self.0 = Some(x.clone());
        }
    }

    /// Runs `f` on `x`; when `guard` is set, saves `x` first and restores it if `f` fails.
    #[inline(always)]
    fn run(
        &mut self,
        guard: bool,
        x: &mut V,
        f: impl FnOnce(&mut V) -> Result<(), StepError>,
    ) -> Result<(), StepError> {
        if !guard {
            return f(x);
        }
        self.prepare(x);
        let b = self.0.as_mut().expect("prepared above");
        b.copy_from(x);
        let r = f(x);
        if r.is_err() {
            x.copy_from(b);
        }
        r
    }
}
