import type { BufferGeometry, Intersection, Raycaster } from 'three';
import type { Scene, SceneOptions } from './core.js';

/** The kd-tree of a BufferGeometry, kept as `geometry.boundsTree`. */
export declare class KdTree {
  constructor(geometry: BufferGeometry, options?: SceneOptions);
  readonly scene: Scene;
  readonly geometry: BufferGeometry;
  dispose(): void;
}
/** Loads the WebAssembly module ahead of time (optional: computeBoundsTree compiles it on first use). */
export declare function init(): Promise<void>;
/** A BufferGeometry method: builds `this.boundsTree`. */
export declare function computeBoundsTree(this: BufferGeometry, options?: SceneOptions): KdTree;
/** A BufferGeometry method: frees `this.boundsTree`. */
export declare function disposeBoundsTree(this: BufferGeometry): void;
/** Mesh.raycast over the kd-tree (three's own without one); honours raycaster.firstHitOnly. */
export declare function acceleratedRaycast(this: any, raycaster: Raycaster, intersects: Intersection[]): void;

declare module 'three' {
  interface BufferGeometry {
    boundsTree?: KdTree | null;
    computeBoundsTree(options?: SceneOptions): KdTree;
    disposeBoundsTree(): void;
  }
  interface Raycaster {
    firstHitOnly?: boolean;
  }
}
