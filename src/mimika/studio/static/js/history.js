// Undo/redo over committed states. The editor calls commit() after every finished edit
// (a slider let go, a trigger dropped, a project loaded); undo() and redo() hand back the state
// to restore. States are JSON strings, so nothing shared can change them afterwards.

export class History {
  constructor(snapshot, { limit = 200, onChange = () => {} } = {}) {
    this.snapshot = snapshot;   // () → the current state (any JSON value)
    this.limit = limit;
    this.onChange = onChange;
    this.reset();
  }

  reset() {
    this.undos = [];
    this.redos = [];
    this.current = JSON.stringify(this.snapshot());
    this.onChange(this);
  }

  // Record the state after an edit; a no-op when nothing changed.
  commit() {
    const now = JSON.stringify(this.snapshot());
    if (now === this.current) return false;
    this.undos.push(this.current);
    if (this.undos.length > this.limit) this.undos.shift();
    this.redos = [];
    this.current = now;
    this.onChange(this);
    return true;
  }

  get canUndo() { return this.undos.length > 0; }
  get canRedo() { return this.redos.length > 0; }

  // The state to restore, or null.
  undo() {
    this.commit();  // an edit still in progress counts first
    if (!this.undos.length) return null;
    this.redos.push(this.current);
    this.current = this.undos.pop();
    this.onChange(this);
    return JSON.parse(this.current);
  }

  redo() {
    if (this.commit() || !this.redos.length) return null;
    this.undos.push(this.current);
    this.current = this.redos.pop();
    this.onChange(this);
    return JSON.parse(this.current);
  }
}
